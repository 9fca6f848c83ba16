"""``miketalk dub`` and ``say --background`` on a synthetic person whose head motion is known.

The person is the synthetic head of ``test_stabilize`` (a textured face on a
plain background whose mouth opens and closes), its model 16 images of the
head at different mouth openings (zero flows: a cross-dissolve is enough
here), its background 40 frames of the head moved by known similarities.
"""

from __future__ import annotations

import json
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from test_stabilize import H, W, _clip, _head, _write_video

from miketalk import cli
from miketalk.composite.background import background_from_video, pingpong
from miketalk.composite.registration import register_video
from miketalk.errors import MiketalkError
from miketalk.flow import pair_path, write_flow_pair
from miketalk.media.decode import read_video
from miketalk.media.images import write_png
from miketalk.media.video import probe_durations
from miketalk.model.background import save_background
from miketalk.model.face import Model
from miketalk.model.write import build_model
from miketalk.stabilize import Stabilizer
from miketalk.visemes import VISEMES


def _model(root: Path, *, person: bool) -> Path:
    images = {}
    for i, viseme in enumerate(VISEMES):
        images[viseme] = root / "src" / f"{i}.png"
        images[viseme].parent.mkdir(parents=True, exist_ok=True)
        write_png(images[viseme], _head(0.5 + 0.5 * i))
    flows = root / "flows"
    flows.mkdir()
    zero = np.zeros((H, W, 2), np.float32)
    for i, a in enumerate(VISEMES):
        for b in VISEMES[i + 1 :]:
            write_flow_pair(
                pair_path(flows, a, b), zero, zero, source=a, target=b,
                estimator="ground_truth", settings={},
            )  # fmt: skip
    model = build_model(
        root / "model", images=images, flows_dir=flows, estimator="ground_truth", settings={}
    )
    if person:
        frames, _ = _clip(40)
        reference = _head(2)
        stabilizer = Stabilizer.from_reference(reference, sample=frames)
        # its head jumps from frame to frame (known similarities): kept unsmoothed
        background = background_from_video(frames, 25.0, stabilizer, source="synthetic", smooth=0)
        save_background(
            model, background, reference=reference, face=stabilizer.face,
            mouth_box=stabilizer.mouth_box, clip="synthetic",
        )  # fmt: skip
    return model


@pytest.fixture(scope="module")
def person(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _model(tmp_path_factory.mktemp("person"), person=True)


@pytest.fixture(scope="module")
def still_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _model(tmp_path_factory.mktemp("still"), person=False)


@pytest.fixture(scope="module")
def video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    frames, _ = _clip(30)  # 1.2 s at 25 fps
    path = tmp_path_factory.mktemp("video") / "person.mkv"
    _write_video(path, frames, "25")
    return path


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def _error(capsys, *args: str) -> str:
    code, out, err = _run(capsys, *args)
    assert code == 2, (out, err)
    lines = [line for line in err.splitlines() if line.startswith("miketalk: error")]
    assert len(lines) == 1, err
    return lines[0]


def test_pingpong_loops_without_a_jump():
    seq = [pingpong(i, 4) for i in range(12)]
    assert seq == [0, 1, 2, 3, 2, 1, 0, 1, 2, 3, 2, 1]
    assert all(abs(a - b) == 1 for a, b in pairwise(seq))
    assert pingpong(5, 1) == 0


def test_the_background_round_trips_through_the_model(person: Path):
    with Model(person) as model:
        background = model.background()
    assert len(background) == 40 and background.fps == 25.0
    _, truth = _clip(40)
    # the registration recovers the known motion (reference pixel -> frame): 0.29 px and
    # 0.003 measured
    error = np.abs(background.transforms - truth)
    assert error[:, :, 2].max() < 0.5 and error[:, :, :2].max() < 0.01


def test_dub_plays_the_speech_over_the_video_at_its_size_and_rate(
    capsys, tmp_path: Path, person: Path, video: Path
):
    out = tmp_path / "dub.mp4"
    code, _, _ = _run(
        capsys, "dub", str(video), "--text", "Bin blue.", "--model", str(person), "-o", str(out)
    )
    assert code == 0
    frames, fps = read_video(out)
    assert fps == 25.0 and frames.shape[1:] == (H, W, 3)
    doc = json.loads(out.with_suffix(".json").read_text())
    assert doc["fps"] == 25.0 and doc["background"]["frames"] == 30
    assert len(frames) == len(doc["frames"])
    source, _ = read_video(video)
    k = min(len(frames), len(source)) - 1
    # above the mouth (the eyes and brows) every frame is the video's own
    rows = slice(20, 60)
    diff = np.abs(frames[: k + 1, rows].astype(int) - source[: k + 1, rows].astype(int))
    assert diff.mean() < 4.0
    # about the mouth (88, 104) every frame is the model's drawing, not the video's own
    # mouth (measured: 11.5 to 41.6 grey levels apart a frame; the eyes' codec noise 1.7-2.1)
    drawn = np.abs(
        frames[: k + 1, 94:116, 68:108].astype(int) - source[: k + 1, 94:116, 68:108].astype(int)
    )
    assert drawn.mean(axis=(1, 2, 3)).min() > 3 * diff.mean(axis=(1, 2, 3)).max()
    # and the speech plays with it, as long as the video it made
    video_s, audio_s = probe_durations(out)
    assert audio_s > 1.0 and abs(audio_s - video_s) <= 1 / 25
    first = out.read_bytes()
    assert _run(capsys, "dub", str(video), "--text", "Bin blue.", "--model", str(person),
                "-o", str(out))[0] == 0  # fmt: skip
    assert out.read_bytes() == first  # deterministic


def test_speech_longer_than_the_video_loops_it(capsys, tmp_path, person, video):
    out = tmp_path / "long.mp4"
    text = "Bin blue at F two now, and place red by G nine soon, please, again and again."
    code, stdout, _ = _run(capsys, "dub", str(video), "--text", text, "--model", str(person),
                           "-o", str(out))  # fmt: skip
    assert code == 0 and "(looped, paper lip-sync)" in stdout  # its model has no other
    frames, _ = read_video(out)
    assert len(frames) > 30


def _write(path: Path, frames: np.ndarray) -> Path:
    _write_video(path, frames, "25")
    return path


@pytest.mark.parametrize(
    ("what", "expected"),
    [
        ("nobody", "does not show the model's person"),
        ("two faces", "shows the model's face twice"),
        ("colours swapped", "colour is far from the model's"),
        ("mirrored", "does not show the model's person"),
        ("short", "at least 1 s"),
        ("unreadable", "is not a video ffmpeg can read"),
        ("missing", "not found"),
    ],
)
def test_a_video_that_cannot_be_dubbed_is_one_line(capsys, tmp_path, person, what, expected):
    path = tmp_path / "v.mkv"
    if what == "nobody":
        _write(path, np.full((30, H, W, 3), (40, 120, 200), np.uint8))
    elif what == "two faces":  # the head twice side by side, each as large as the model's
        frames = _clip(30)[0][:, :, 44:132]
        _write(path, np.concatenate([frames, frames], axis=2))
    elif what == "colours swapped":  # registers on grey levels as well as the original
        _write(path, np.ascontiguousarray(_clip(30)[0][..., ::-1]))
    elif what == "mirrored":
        _write(path, np.ascontiguousarray(_clip(30)[0][:, :, ::-1]))
    elif what == "short":
        _write(path, _clip(20)[0])
    elif what == "unreadable":
        path.write_text("not a video")
    out = tmp_path / "o.mp4"
    line = _error(capsys, "dub", str(path), "--text", "Bin blue.", "--model", str(person),
                  "-o", str(out))  # fmt: skip
    assert expected in line
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_a_trackers_crops_are_not_searched_for_a_second_copy_of_the_face():
    """In a face crop the face's own shifted copy matches the reference at up to 0.62 (a
    weekly address of one man was refused as showing "the model's face twice"): the crops
    of a tracker, which counted the faces in the whole frame, are not searched; a model in
    the video's own pixels still refuses two copies of the face."""
    frames, _ = _clip(30)
    stabilizer = Stabilizer.from_reference(_head(2), sample=frames)
    two = np.ascontiguousarray(np.concatenate([frames[:, :, 44:132]] * 2, axis=2))
    with pytest.raises(MiketalkError, match="shows the model's face twice"):
        register_video(two, 25.0, stabilizer, smooth=0)
    found = register_video(two, 25.0, stabilizer, smooth=0, refine=True)
    assert np.isfinite(found.transforms).all()


def _mp4(path: Path, frames: int, *, faststart: bool) -> Path:
    """The synthetic head's ``frames`` at 25 fps as an H.264 mp4 (its index at its end, or
    first with ``faststart``), without B-frames: cut short, its packets' timestamps have no
    gaps (with B-frames they can, and the cut file is then read as a variable frame rate)."""
    import subprocess

    import imageio_ffmpeg

    lossless = _write(path.with_suffix(".mkv"), _clip(frames)[0])
    subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-y", "-i", str(lossless),
            "-c:v", "libx264", "-pix_fmt", "yuv420p", "-threads", "1", "-bf", "0",
            *(["-movflags", "+faststart"] if faststart else []), str(path),
        ],
        check=True, capture_output=True,
    )  # fmt: skip
    return path


@pytest.mark.parametrize("what", ["text", "first 2000 bytes", "first half"])
def test_a_file_ffmpeg_cannot_open_is_said_in_plain_words(capsys, tmp_path, person, what):
    path = tmp_path / "v.mp4"
    if what == "text":
        path.write_text("not a video\n")
    else:  # its index (moov) at its end: a part is no mp4 to ffmpeg
        data = _mp4(tmp_path / "whole.mp4", 75, faststart=False).read_bytes()
        path.write_bytes(data[:2000] if what == "first 2000 bytes" else data[: len(data) // 2])
    out = tmp_path / "o.mp4"
    line = _error(capsys, "dub", str(path), "--text", "Bin blue.", "--model", str(person),
                  "-o", str(out))  # fmt: skip
    # before: "ffmpeg could not decode v.mp4: [in#0 @ 0x...] Error opening input: ... |
    # Exiting with exit code -1094995529", ffmpeg's own words
    assert line == (
        f"miketalk: error: {path} is not a video ffmpeg can read (cut short, or another kind "
        "of file); -v shows ffmpeg's own words"
    )
    assert not out.exists()


def test_a_video_that_ends_before_its_stated_duration_is_dubbed_with_a_warning(
    capsys, caplog, tmp_path, person
):
    whole = _mp4(tmp_path / "whole.mp4", 75, faststart=True)  # 3 s, its index first
    half = tmp_path / "half.mp4"
    data = whole.read_bytes()
    half.write_bytes(data[: len(data) // 2])
    for video in (whole, half):
        code, out, err = _run(
            capsys, "dub", str(video), "--text", "Bin blue at F two now.", "--model",
            str(person), "-o", str(tmp_path / f"dub_{video.name}"),
        )  # fmt: skip
        assert code == 0, err
        early = [m for m in caplog.messages if "ends early" in m]  # the command's warnings
        caplog.clear()
        if video == whole:
            assert early == [], err
            continue
        # before: dubbed over the frames that decode without a word (exit 0)
        assert len(early) == 1, err
        frames = int(early[0].split("its ")[1].split(" frames")[0])
        assert 25 < frames < 75
        assert f"last {frames / 25:.2f} s of the 3.00 s the file states" in early[0]
        assert f"over {frames} frames of" in out


def test_dub_needs_a_model_of_a_person_and_something_to_say(
    capsys, tmp_path, person, still_model, video
):
    out = str(tmp_path / "o.mp4")
    line = _error(capsys, "dub", str(video), "--text", "Hi.", "--model", str(still_model),
                  "-o", out)  # fmt: skip
    assert "not built from video of a person" in line
    assert "--text" in _error(capsys, "dub", str(video), "--model", str(person), "-o", out)


def test_say_background_auto_is_still_for_a_model_without_one(capsys, tmp_path, still_model):
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    assert _run(capsys, "say", "Bin blue.", "--model", str(still_model), "-o", str(a))[0] == 0
    assert _run(capsys, "say", "Bin blue.", "--model", str(still_model), "-o", str(b),
                "--background", "still")[0] == 0  # fmt: skip
    assert a.read_bytes() == b.read_bytes()
    assert "background" not in json.loads(a.with_suffix(".json").read_text())


def test_say_background_auto_moves_the_head(capsys, tmp_path, person, video):
    auto, still = tmp_path / "auto.mp4", tmp_path / "still.mp4"
    assert _run(capsys, "say", "Bin blue.", "--model", str(person), "-o", str(auto))[0] == 0
    assert _run(capsys, "say", "Bin blue.", "--model", str(person), "-o", str(still),
                "--background", "still")[0] == 0  # fmt: skip
    moving, _ = read_video(auto)
    fixed, _ = read_video(still)
    eyes = slice(20, 60)
    # the still face's eyes never move; the background's move with the head
    assert np.abs(np.diff(fixed[:, eyes].astype(int), axis=0)).mean() < 1.0
    assert np.abs(np.diff(moving[:, eyes].astype(int), axis=0)).mean() > 3.0
    doc = json.loads(auto.with_suffix(".json").read_text())
    assert doc["background"]["loop"] == "pingpong"
    video_bg = tmp_path / "v.mp4"
    code, _, _ = _run(capsys, "say", "Bin blue.", "--model", str(person), "-o", str(video_bg),
                      "--background", str(video))  # fmt: skip
    assert code == 0
    assert read_video(video_bg)[0].shape[1:] == (H, W, 3)


def test_lower_face_correlation_tells_a_mouth_in_place_from_one_that_is_not():
    from miketalk.composite.registration import lower_face_correlation

    frame = _head(4)
    box = (74, 100, 28, 8)  # the synthetic mouth: centre (88, 104), 28 px wide
    assert lower_face_correlation(frame, frame, box) == pytest.approx(1.0)
    assert lower_face_correlation(np.roll(frame, 30, axis=0), frame, box) < 0.4


def test_the_background_turns_where_the_head_stands_still():
    from miketalk.composite.loop import head_speed, still_window

    speed = np.full(75, 0.5)
    speed[[3, 40, 60]] = 0.01  # still at frames 3, 40 and 60
    assert still_window(speed, (), shortest=50, longest=75) == (3, 61)
    # a blink at 70 must stay in: the ends still at 40 (or 3) and the last frame
    speed[74] = 0.02
    assert still_window(speed, (70,), shortest=30, longest=75) == (3, 75)
    assert still_window(speed, (70,), shortest=30, longest=40) == (40, 75)
    # a head moving 1 px per frame to the right, then standing
    shifts = np.tile(np.eye(2, 3), (20, 1, 1))
    shifts[:, 0, 2] = np.minimum(np.arange(20), 10)
    moving = head_speed(shifts, (5.0, 5.0))
    assert moving[1:9] == pytest.approx(1.0) and moving[12:] == pytest.approx(0.0)


def test_smoothing_in_time_is_scipys_gaussian_filter():
    from scipy.ndimage import gaussian_filter1d

    from miketalk.composite.loop import smooth_in_time

    for n in (2, 5, 75):
        t = np.random.default_rng(n).normal(size=(n, 2, 3))
        expected = gaussian_filter1d(t, 1.0, axis=0, mode="nearest")
        assert np.allclose(smooth_in_time(t, 1.0), expected, atol=1e-12)


def test_a_video_without_a_face_anywhere_is_refused_after_a_first_look(tmp_path, monkeypatch):
    """A dub of a video with no frontal face anywhere (a profile, the picture turned on its
    side) tracked all its frames before refusing (37 s for 394 720p frames, where build
    looks at 7): now a first look at 7 frames spread over it refuses with build's line, and
    a video that shows the face in some frames only is tracked as before."""
    from types import SimpleNamespace

    from miketalk.composite import for_model, tracked
    from miketalk.track import detect
    from miketalk.track.crop import FaceCropSettings

    model = SimpleNamespace(stabilizer=lambda: None, crop=FaceCropSettings())
    monkeypatch.setattr(tracked, "tracked_background", lambda video, *a, **k: ("tracked", video))
    looked, real = [], detect.detect_faces
    monkeypatch.setattr(
        detect, "detect_faces", lambda image, **k: looked.append(1) or real(image, **k)
    )
    nobody = _write(tmp_path / "nobody.mkv", _clip(30)[0])  # the synthetic head: no dlib face
    with pytest.raises(MiketalkError) as refused:
        for_model.video_background(model, nobody)
    assert str(refused.value) == (
        f"no face found in {nobody} (7 of 7 frames looked at show none): it needs one "
        "person's frontal face"
    )
    assert len(looked) <= 14  # 7 frames, at the tracker's two scales at most
    grid = Path(__file__).parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"
    some, _ = read_video(grid, frames=40)
    some[:28] = 128  # his face in the last 12 frames only
    path = _write(tmp_path / "some.mkv", some)
    # the stand-in model has no reference to compare the person with (test_identity does)
    tracked_path = for_model.video_background(model, path, check_person=False)
    assert tracked_path == ("tracked", path)


def test_dub_with_no_model_takes_the_videos_own_from_the_cache(
    capsys, tmp_path: Path, person: Path, video: Path, monkeypatch: pytest.MonkeyPatch
):
    """No ``--model``: the model kept under the video's checksum is used (a second dub of
    the same video starts at once); with none there, the output's mistake is said before a
    build starts."""
    import importlib
    import shutil

    from miketalk.api import video_model

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("MIKETALK_MODEL", raising=False)
    builds: list[tuple] = []
    building = importlib.import_module("miketalk.api.build")
    monkeypatch.setattr(building, "build", lambda *a, **k: builds.append(a))
    line = _error(capsys, "dub", str(video), "--text", "Bin blue.", "-o", str(tmp_path / "o.txt"))
    assert ".mp4" in line and builds == []
    cached = tmp_path / "cache" / "video-models" / video_model.video_digest(video)[:32]
    shutil.copytree(person, cached)
    out = tmp_path / "dub.mp4"
    code, _, err = _run(capsys, "dub", str(video), "--text", "Bin blue.", "-o", str(out))
    assert code == 0, err
    assert builds == [] and out.is_file()  # no build, and no other model to take
    shutil.rmtree(cached)  # not there: built (here a stand-in that builds nothing)
    _error(capsys, "dub", str(video), "--text", "Bin blue.", "-o", str(out))
    assert [Path(b[1]) for b in builds] == [cached]
    other = tmp_path / "other.mkv"
    other.write_bytes(video.read_bytes() + b"\0")  # another file: another model
    assert video_model.video_digest(other) != video_model.video_digest(video)
    monkeypatch.setenv("MIKETALK_CACHE", "off")  # nowhere to keep it: said, not built
    line = _error(capsys, "dub", str(video), "--text", "Bin blue.", "-o", str(out))
    assert "no cache" in line and len(builds) == 1
