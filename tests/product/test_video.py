"""Tests of miketalk.media.video (mp4 output, duration probe) and miketalk.media.audio (wav)."""

from __future__ import annotations

import json
import os
import tempfile
import wave
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.media.audio import read_wav, write_wav
from miketalk.media.video import probe_durations, write_mp4

RATE = 16000


def _frames(n: int, h: int = 48, w: int = 64, seed: int = 0) -> np.ndarray:
    """A moving gradient with a little noise: ``(n, h, w, 3)`` uint8."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:h, 0:w]
    frames = np.stack([(xs * 4 + ys * 2 + 9 * k) % 256 for k in range(n)])
    rgb = np.stack([frames, frames[:, ::-1], 255 - frames], axis=-1)
    return (rgb + rng.integers(0, 8, rgb.shape)).clip(0, 255).astype(np.uint8)


def _tone(seconds: float) -> np.ndarray:
    t = np.arange(round(seconds * RATE)) / RATE
    return (8000 * np.sin(2 * np.pi * 440 * t)).astype(np.int16)


@pytest.mark.parametrize(("fps", "audio_seconds"), [(25, 0.8), (30, 0.3), (29.97, 0.6)])
def test_durations_are_equal_within_one_frame(tmp_path, fps, audio_seconds):
    n = 20
    path = tmp_path / "out" / "talk.mp4"
    write_mp4(path, _frames(n), fps=fps, audio=_tone(audio_seconds), rate=RATE)  # trimmed, padded
    video, audio = probe_durations(path)
    assert video == pytest.approx(n / fps, abs=1e-6)
    assert abs(audio - video) <= 1 / RATE + 1e-9
    assert abs(audio - video) < 1 / fps


def test_same_input_gives_identical_bytes(tmp_path):
    frames, audio = _frames(12), _tone(0.5)
    write_mp4(tmp_path / "a.mp4", frames, fps=25, audio=audio, rate=RATE)
    write_mp4(
        tmp_path / "b.mp4", iter(list(frames)), fps=25, audio=audio, rate=RATE, n_frames=len(frames)
    )  # streamed
    assert (tmp_path / "a.mp4").read_bytes() == (tmp_path / "b.mp4").read_bytes()


def test_known_frame_count_writes_in_one_pass(tmp_path):
    frames, audio = _frames(15), _tone(0.45)
    path = tmp_path / "one.mp4"
    write_mp4(path, iter(list(frames)), fps=30, audio=audio, rate=RATE, n_frames=15)
    video, sound = probe_durations(path)
    assert video == pytest.approx(0.5, abs=1e-6) and abs(sound - video) < 1 / 30
    write_mp4(tmp_path / "two.mp4", list(frames), fps=30, audio=audio, rate=RATE)
    assert path.read_bytes() == (tmp_path / "two.mp4").read_bytes()


@pytest.mark.parametrize("count", [14, 16])
def test_wrong_frame_count_is_an_error_and_leaves_nothing(tmp_path, count):
    path = tmp_path / "bad.mp4"
    with pytest.raises(MiketalkError, match="15 frames were given, not n_frames="):
        write_mp4(path, _frames(15), fps=30, audio=_tone(0.5), rate=RATE, n_frames=count)
    assert list(tmp_path.iterdir()) == []


def test_grey_odd_sized_frames_without_audio(tmp_path):
    frames = _frames(5, h=33, w=45)[..., 0]
    write_mp4(tmp_path / "grey.mp4", frames, fps=10)
    assert probe_durations(tmp_path / "grey.mp4") == (pytest.approx(0.5), 0.0)


def _bad_stream(n_good: int) -> Iterator[np.ndarray]:
    yield from _frames(n_good)
    yield np.zeros((10, 10, 3), np.uint8)


def _interrupted_stream(n_good: int) -> Iterator[np.ndarray]:
    yield from _frames(n_good)
    raise KeyboardInterrupt


@pytest.mark.parametrize(
    ("stream", "error", "match"),
    [
        (_bad_stream, MiketalkError, "frame 7 has shape"),
        (_interrupted_stream, KeyboardInterrupt, None),
    ],
)
def test_failure_mid_stream_leaves_nothing_behind(tmp_path, monkeypatch, stream, error, match):
    scratch = tmp_path / "scratch"  # where the intermediate files go
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    out = tmp_path / "out"
    with pytest.raises(error, match=match):
        write_mp4(out / "bad.mp4", stream(7), fps=25, audio=_tone(0.3), rate=RATE, n_frames=7)
    assert not out.exists() or list(out.iterdir()) == []
    assert list(scratch.iterdir()) == []


def test_failure_keeps_an_existing_file(tmp_path):
    path = tmp_path / "keep.mp4"
    path.write_bytes(b"old")
    with pytest.raises(MiketalkError, match="dtype"):
        write_mp4(path, [np.zeros((8, 8, 3), np.float32)], fps=25)
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.mp4"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fps": 0}, "fps"),
        ({"fps": float("nan")}, "fps"),
        ({"audio": _tone(0.1).astype(np.float32)}, "audio"),
        ({"audio": np.zeros((10, 2), np.int16)}, "audio"),
        ({"rate": None}, "rate"),
        ({"rate": 0}, "rate"),
        ({"crf": 60}, "crf"),
        ({"frames": []}, "empty"),
        ({"frames": np.zeros((8, 8, 3), np.uint8)}, "one RGB image"),
        ({"frames": [np.zeros((8, 8, 4), np.uint8)]}, "frame 0"),
    ],
)
def test_bad_arguments(tmp_path, kwargs, match):
    args = {"frames": _frames(2), "fps": 25, "audio": _tone(0.1), "rate": RATE, **kwargs}
    with pytest.raises(MiketalkError, match=match):
        write_mp4(tmp_path / "x.mp4", **args)
    assert list(tmp_path.iterdir()) == []


def test_probe_missing_file(tmp_path):
    with pytest.raises(MiketalkError, match="not found"):
        probe_durations(tmp_path / "nope.mp4")
    (tmp_path / "junk.mp4").write_bytes(b"not a video")
    with pytest.raises(MiketalkError, match="could not read"):
        probe_durations(tmp_path / "junk.mp4")


# ------------------------------------------------------------------------- wav


def test_wav_round_trip(tmp_path):
    samples = _tone(0.25)
    write_wav(tmp_path / "a" / "t.wav", samples, RATE)
    back, rate = read_wav(tmp_path / "a" / "t.wav")
    assert rate == RATE and back.dtype == np.int16
    np.testing.assert_array_equal(back, samples)
    assert [p.name for p in (tmp_path / "a").iterdir()] == ["t.wav"]


def test_wav_errors(tmp_path):
    with pytest.raises(MiketalkError, match="not found"):
        read_wav(tmp_path / "missing.wav")
    stereo = tmp_path / "stereo.wav"
    with wave.open(str(stereo), "wb") as out:
        out.setnchannels(2)
        out.setsampwidth(2)
        out.setframerate(RATE)
        out.writeframes(b"\0" * 40)
    with pytest.raises(MiketalkError, match="mono 16-bit"):
        read_wav(stereo)
    Path(tmp_path / "junk.wav").write_bytes(b"RIFFjunk")
    with pytest.raises(MiketalkError, match="not a readable"):
        read_wav(tmp_path / "junk.wav")
    with pytest.raises(MiketalkError, match="int16"):
        write_wav(tmp_path / "f.wav", np.zeros(4, np.float32), RATE)
    with pytest.raises(MiketalkError, match="rate"):
        write_wav(tmp_path / "f.wav", np.zeros(4, np.int16), 0)
    assert not (tmp_path / "f.wav").exists()


# ---------------------------------------------------------------------------
# files replaced together, and what killed runs leave
# ---------------------------------------------------------------------------


def _dead_tag() -> str:
    """A tag whose owner is gone: this process's id with another start time."""
    from miketalk.media.scratch import owner_tag

    pid, start = owner_tag().split(".")
    return f"{pid}.{int(start) + 12345}"


def test_atomic_paths_replace_files_together_or_not_at_all(tmp_path):
    from miketalk.media.atomic import atomic_paths

    old = {"v.mp4": b"old video", "v.json": b"old json"}
    for name, data in old.items():
        (tmp_path / name).write_bytes(data)
    with (
        pytest.raises(RuntimeError),
        atomic_paths([tmp_path / "v.mp4", tmp_path / "v.json"]) as (
            video,
            timeline,
        ),
    ):
        video.write_bytes(b"new video")
        assert video.name.startswith(".v.mp4.miketalk-") and video.suffix == ".mp4"
        raise RuntimeError("the render failed")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == old
    with atomic_paths([tmp_path / "v.mp4", tmp_path / "v.json"]) as (video, timeline):
        video.write_bytes(b"new video")
        timeline.write_bytes(b"new json")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == {
        "v.mp4": b"new video", "v.json": b"new json",
    }  # fmt: skip


def test_a_commit_cut_short_by_a_kill_is_finished_by_the_next_run(tmp_path):
    from miketalk.media.atomic import sweep_beside

    tag = _dead_tag()
    (tmp_path / "v.mp4").write_bytes(b"old video")
    (tmp_path / "v.json").write_bytes(b"new json")  # renamed before the kill
    new_video = tmp_path / f".v.mp4.miketalk-{tag}.abc123.mp4"
    new_video.write_bytes(b"new video")
    journal = tmp_path / f".v.mp4.miketalk-{tag}.commit"
    journal.write_text(json.dumps([[new_video.name, "v.mp4"], [".v.json.x.json", "v.json"]]))
    orphan = tmp_path / f".w.mp4.miketalk-{tag}.def456.mp4"  # a render that was killed
    orphan.write_bytes(b"half a video")
    from miketalk.media.scratch import owner_tag

    running = tmp_path / f".w.mp4.miketalk-{owner_tag()}.ghi789.mp4"  # a live run's
    running.write_bytes(b"being written")
    foreign = tmp_path / ".v.mp4.tmp"  # not ours
    foreign.write_bytes(b"someone else's")
    removed = sweep_beside(tmp_path / "v.mp4")
    assert set(removed) == {journal, orphan}
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == {
        "v.mp4": b"new video", "v.json": b"new json", running.name: b"being written",
        foreign.name: b"someone else's",
    }  # fmt: skip


def test_scratch_directories_of_dead_runs_are_swept(tmp_path, monkeypatch):
    from miketalk.media.scratch import owner_tag, scratch_dir

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = tmp_path / f"miketalk-festival-{_dead_tag()}-x1"
    (dead / "sub").mkdir(parents=True)
    (dead / "sub" / "0.wav").write_bytes(b"RIFF")
    alive = tmp_path / f"miketalk-mp4-{owner_tag()}-x2"
    alive.mkdir()
    untagged = tmp_path / "miketalk-mp4-abcdef"  # an older miketalk's: owner unknown
    untagged.mkdir()
    with scratch_dir("mp4") as work:
        assert work.parent == tmp_path and work.name.startswith(f"miketalk-mp4-{owner_tag()}-")
        assert not dead.exists() and alive.exists() and untagged.exists()
    assert not work.exists()
    with pytest.raises(ValueError), scratch_dir("Bad-Kind"):
        pass


def test_a_scratch_tree_is_removed_whole_and_its_links_not_followed(tmp_path):
    """remove_tree (threads unlinking at once: a stopped build's work folder went in 2.6 s
    on a file system that discards freed blocks, in 0.1 s so) removes what rmtree does."""
    from miketalk.media.scratch import REMOVAL_THREADS, remove_tree

    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.txt").write_text("mine")
    tree = tmp_path / "miketalk-build-1.2-x"
    for d in ("corpus/frames", "visemes/images", "empty/deeper"):
        (tree / d).mkdir(parents=True)
    for i in range(5 * REMOVAL_THREADS):
        (tree / "corpus" / "frames" / f"{i:06d}.png").write_bytes(b"\x89PNG" * 100)
    (tree / "visemes" / "images" / "a.png").write_bytes(b"x")
    (tree / "link_to_dir").symlink_to(outside)
    (tree / "corpus" / "link_to_file").symlink_to(outside / "keep.txt")
    (tree / "dangling").symlink_to(tmp_path / "nowhere")
    remove_tree(tree)
    assert not tree.exists() and not tree.is_symlink()
    assert (outside / "keep.txt").read_text() == "mine"
    remove_tree(tree)  # already gone: nothing to do, no error


def test_a_directory_that_cannot_be_written_is_reported_before_writing(tmp_path):
    from miketalk.media.atomic import check_writable

    (tmp_path / "file").write_bytes(b"")
    with pytest.raises(MiketalkError, match="cannot write"):
        check_writable(tmp_path / "file" / "v.mp4")
    check_writable(tmp_path / "new" / "deeper" / "v.mp4")  # made for the check, removed after
    assert not (tmp_path / "new").exists()
    (tmp_path / "there").mkdir()
    check_writable(tmp_path / "there" / "v.mp4")  # a folder that was there stays, empty
    assert list((tmp_path / "there").iterdir()) == []


# ---------------------------------------------------------------------------
# a variable frame rate, read by the frames' timestamps
# ---------------------------------------------------------------------------

GRID_CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"


def _variable_rate_clip(path: Path) -> list[float]:
    """A GRID clip with its sound, its first 1.2 s at 25 fps and the rest at 10 fps (48
    frames over 3 s; ffmpeg states 50 fps); the times its frames are shown."""
    import subprocess

    from miketalk.media.video import ffmpeg_exe

    graph = (
        "[0:v]trim=0:1.2,setpts=PTS-STARTPTS[a];"
        "[0:v]trim=1.2:3,setpts=PTS-STARTPTS,fps=10[b];[a][b]concat=n=2:v=1:a=0[v]"
    )
    subprocess.run(
        [ffmpeg_exe(), "-loglevel", "error", "-y", "-i", str(GRID_CLIP), "-filter_complex", graph,
         "-map", "[v]", "-map", "0:a", "-fps_mode", "vfr", "-c:v", "libx264", "-c:a", "aac",
         str(path)],
        check=True,
    )  # fmt: skip
    return [0.04 * i for i in range(30)] + [1.2 + 0.1 * i for i in range(18)]


def test_a_variable_frame_rate_video_is_read_by_its_timestamps(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import subprocess

    from miketalk.media import decode
    from miketalk.media.decode import iter_video_frames, read_media_audio, read_video
    from miketalk.media.timing import check_constant_rate

    path = tmp_path / "vfr.mp4"
    shown = _variable_rate_clip(path)
    with caplog.at_level("WARNING", logger="miketalk.media.decode"):
        frames, fps = read_video(path)
        samples = read_media_audio(path, rate=RATE)
        again, _ = read_video(path, start=20 / fps, frames=10)
    assert fps == 16.0  # its average: 48 frames over 3 s
    assert abs(len(frames) - 3.0 * fps) <= 1
    assert abs(len(frames) / fps - len(samples) / RATE) <= 1 / fps  # the sound in sync
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1 and "vfr.mp4 has a variable frame rate" in said[0], said
    assert "read at a constant 16 fps" in said[0]
    # frame k is the one on screen at k / fps: the file's frames as they are, picked by time
    plain = subprocess.run(
        decode._video_args(path, "error", None, None), capture_output=True, check=True
    ).stdout
    stored = np.frombuffer(plain, np.uint8).reshape(len(shown), *frames.shape[1:])
    on_screen = [max(i for i, t in enumerate(shown) if t <= k / fps + 1e-9) for k in range(48)]
    assert all((frames[k] == stored[i]).all() for k, i in enumerate(on_screen))
    dropped, repeated = set(range(48)) - set(on_screen), 48 - len(set(on_screen))
    assert dropped and max(dropped) < 30 and repeated > 0  # dropped where 25 fps, repeated where 10
    # a part is the same frames as the whole; the stream gives the same; dub accepts it
    assert (again == frames[20:30]).all()
    assert all((a == b).all() for a, b in zip(iter_video_frames(path), frames, strict=True))
    check_constant_rate(path, fps, len(frames))


def test_a_single_file_write_does_not_list_its_directory(tmp_path, monkeypatch):
    """A frame's write is one rename: it must not scan the folder (quadratic in a video)."""
    from miketalk.media import atomic
    from miketalk.media.atomic import write_bytes_atomic

    for i in range(50):
        (tmp_path / f"{i:05d}.png").write_bytes(b"x")
    listed = []
    real = os.listdir
    monkeypatch.setattr(atomic.os, "listdir", lambda d=".": listed.append(d) or real(d))
    write_bytes_atomic(tmp_path / "00050.png", b"frame")
    assert listed == [] and (tmp_path / "00050.png").read_bytes() == b"frame"


def test_a_stale_journal_does_not_undo_a_newer_file(tmp_path):
    """A unit killed mid-commit, then its first file written anew by itself: the next
    sweep rolls the unit back around the newer file instead of forward over it."""
    from miketalk.media.atomic import sweep_beside, write_bytes_atomic

    tag = _dead_tag()
    (tmp_path / "v.mp4").write_bytes(b"old video")
    (tmp_path / "v.json").write_bytes(b"old json")
    backup = f".v.mp4.miketalk-{tag}.aa.old"
    os.link(tmp_path / "v.mp4", tmp_path / backup)
    new_video = tmp_path / f".v.mp4.miketalk-{tag}.abc.mp4"
    new_video.write_bytes(b"killed unit's video")
    new_json = tmp_path / f".v.json.miketalk-{tag}.def.json"
    new_json.write_bytes(b"killed unit's json")
    files = [
        {"temporary": new_video.name, "final": "v.mp4", "inode": new_video.stat().st_ino,
         "backup": backup},
        {"temporary": new_json.name, "final": "v.json", "inode": new_json.stat().st_ino,
         "backup": f".v.json.miketalk-{tag}.bb.old"},
    ]  # fmt: skip
    (tmp_path / f".v.mp4.miketalk-{tag}.commit").write_text(
        json.dumps({"format": "miketalk-journal/2", "files": files})
    )
    write_bytes_atomic(tmp_path / "v.mp4", b"newer video")
    sweep_beside(tmp_path / "v.mp4")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == {
        "v.mp4": b"newer video", "v.json": b"old json",
    }  # fmt: skip


def test_frames_in_the_encoders_colours_are_encoded_as_given(tmp_path):
    """I420 frames go to the encoder unconverted: losslessly encoded, they decode to the very
    planes given; mixed with RGB frames they are refused, and nothing is left."""
    import subprocess

    from miketalk.media.video import ffmpeg_exe
    from miketalk.media.yuv import I420Frame, to_i420

    planes = [to_i420(f) for f in _frames(6)]
    path = tmp_path / "yuv.mp4"
    write_mp4(path, (I420Frame(p) for p in planes), fps=25, n_frames=6, crf=0)
    decoded = subprocess.run(
        [ffmpeg_exe(), "-v", "error", "-i", str(path), "-f", "rawvideo", "-pix_fmt", "yuv420p",
         "-"], capture_output=True, check=True,
    ).stdout  # fmt: skip
    assert decoded == b"".join(p.tobytes() for p in planes)
    assert np.array_equal(I420Frame(planes[0]).rgb().shape, (48, 64, 3))
    mixed = tmp_path / "mixed.mp4"
    with pytest.raises(MiketalkError, match="frame 1"):
        write_mp4(mixed, [I420Frame(planes[0]), _frames(1)[0]], fps=25)
    assert not mixed.exists()
