"""Tests of miketalk.media.decode (decoding), miketalk.stabilize and miketalk.corpus.steady.

Everything is built here: a seeded synthetic head (a textured ellipse on a
plain background, a neck and shoulders, a dark mouth blob that opens and
closes) moved by known similarity transforms, and tiny videos written with the
bundled ffmpeg. Nothing reads /work/shared.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import cv2
import imageio_ffmpeg
import numpy as np
import pytest

from miketalk.corpus.clip_sources import RATE, Clip, ClipError, DecodedClip
from miketalk.corpus.clips import ingest_clips
from miketalk.corpus.steady import kept_frames, speech_span, stabilize_clip
from miketalk.errors import MiketalkError
from miketalk.media.decode import read_video
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming
from miketalk.stabilize import (
    Stabilizer,
    choose_reference,
    locate_face,
    locate_head,
    locate_mouth,
    registration_mask,
    residual_motion,
)

H, W = 144, 176
MOUTH = (88, 104)  # centre (x, y) of the synthetic mouth


def _texture(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """Smooth noise in [-1, 1] (detail at 2.5 and 6 px): any interpolation resamples it well."""
    fine = cv2.GaussianBlur(rng.standard_normal(shape).astype(np.float32), (0, 0), 2.5)
    coarse = cv2.GaussianBlur(rng.standard_normal(shape).astype(np.float32), (0, 0), 6.0)
    tex = fine / fine.std() + 0.7 * coarse / coarse.std()
    return np.clip(tex / 3, -1, 1)


def _head(opening: float, seed: int = 7) -> np.ndarray:
    """The synthetic head, mouth ``opening`` px tall: (H, W, 3) uint8 RGB."""
    rng = np.random.default_rng(seed)
    img = np.empty((H, W, 3), np.float32)
    img[:] = (40, 120, 200)  # plain blue background
    yy, xx = np.mgrid[0:H, 0:W]
    body = np.zeros((H, W), bool)
    body |= ((xx - 88) / 40) ** 2 + ((yy - 70) / 52) ** 2 <= 1  # head
    body |= (abs(xx - 88) <= 20) & (yy >= 110)  # neck
    body |= (abs(xx - 88) <= 80) & (yy >= 132)  # shoulders
    tex = _texture(rng, (H, W))
    skin = np.array([200, 150, 120], np.float32)
    img[body] = skin + 60 * tex[body, None]
    mouth = ((xx - MOUTH[0]) / 14) ** 2 + ((yy - MOUTH[1]) / max(opening, 0.5)) ** 2 <= 1
    img[mouth] = np.array([150, 60, 70], np.float32) * (1 - 0.1 * opening)  # darker as it opens
    return np.clip(img, 0, 255).astype(np.uint8)


def _similarity(k: int) -> np.ndarray:
    """Frame ``k``'s known motion: a small shift, rotation and scale about the head."""
    angle = 2.0 * np.sin(0.7 * k)  # degrees
    scale = 1 + 0.02 * np.cos(0.5 * k)
    m = cv2.getRotationMatrix2D((88.0, 70.0), angle, scale)
    m[:, 2] += (2.5 * np.sin(0.9 * k + 1), 1.5 * np.cos(1.1 * k))
    return m


def _clip(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Frames whose head is the synthetic head moved by ``_similarity(k)`` (frame 0 unmoved)."""
    frames, truth = [], []
    for k in range(n):
        m = np.eye(2, 3) if k == 0 else _similarity(k)
        head = _head(2 + 5 * abs(np.sin(0.8 * k)))
        frames.append(
            cv2.warpAffine(head, m, (W, H), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
        )
        truth.append(m)
    return np.stack(frames), np.stack(truth)


# --- read_video --------------------------------------------------------------------------


def _write_video(path, frames: np.ndarray, rate: str) -> None:
    """Write RGB frames losslessly (FFV1 in Matroska) with one-thread, bit-exact ffmpeg."""
    _, h, w, _ = frames.shape
    args = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-y", "-threads", "1",
        "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r", rate, "-i", "pipe:0",
        "-c:v", "ffv1", "-pix_fmt", "bgr0", "-threads", "1", "-bitexact", str(path),
    ]  # fmt: skip
    subprocess.run(args, input=frames.tobytes(), check=True, capture_output=True)


def test_read_video_returns_the_frames_and_the_exact_rate(tmp_path):
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (7, 24, 32, 3), dtype=np.uint8)
    path = tmp_path / "clip.mkv"
    _write_video(path, frames, "30000/1001")
    got, fps = read_video(path)
    assert got.dtype == np.uint8 and got.shape == frames.shape
    np.testing.assert_array_equal(got, frames)
    assert fps == float(Fraction(30000, 1001))
    again, _ = read_video(str(path))
    assert again.tobytes() == got.tobytes()


def test_read_video_decodes_mpeg1_at_25_fps_deterministically(tmp_path):
    path = tmp_path / "grid_like.mpg"
    args = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-y", "-threads", "1",
        "-f", "lavfi", "-i", "testsrc=size=64x48:rate=25:duration=0.4",
        "-c:v", "mpeg1video", "-threads", "1", "-bitexact", str(path),
    ]  # fmt: skip
    subprocess.run(args, check=True, capture_output=True)
    first, fps = read_video(path)
    second, _ = read_video(path)
    assert first.shape == (10, 48, 64, 3) and fps == 25.0
    assert first.tobytes() == second.tobytes()


def test_read_video_names_a_missing_or_unreadable_file(tmp_path):
    with pytest.raises(MiketalkError, match=r"nothere\.mpg"):
        read_video(tmp_path / "nothere.mpg")
    junk = tmp_path / "junk.mpg"
    junk.write_bytes(b"not a video at all" * 10)
    with pytest.raises(MiketalkError, match=r"junk\.mpg"):
        read_video(junk)


def test_read_video_rejects_a_file_without_video(tmp_path):
    path = tmp_path / "tone.wav"
    args = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-y",
        "-f", "lavfi", "-i", "sine=duration=0.2", str(path),
    ]  # fmt: skip
    subprocess.run(args, check=True, capture_output=True)
    with pytest.raises(MiketalkError, match=r"tone\.wav has no video stream"):
        read_video(path)


# --- where the face and the mouth are --------------------------------------------------------


def test_locate_head_and_face_find_the_head_above_the_neck():
    frame = _head(4.0)
    head = locate_head(frame)
    face = locate_face(frame)
    assert head[70, 88] and face[70, 88] and face[MOUTH[1], MOUTH[0]]
    assert not head[5, 5] and not head[140, 88]  # background; shoulders below the neck
    assert not face[125, 88]  # neck
    assert (face & ~head).sum() == 0


def test_locate_mouth_finds_the_moving_blob():
    frames = np.stack([_head(2 + 5 * abs(np.sin(0.8 * k))) for k in range(12)])
    x, y, w, h = locate_mouth(frames, locate_face(frames[0]))
    assert x <= MOUTH[0] < x + w and y <= MOUTH[1] < y + h
    assert w <= 40 and h <= 24  # the mouth, not the face


def test_registration_mask_is_the_face_outside_the_mouth():
    frame = _head(4.0)
    face = locate_face(frame)
    box = (74, 97, 29, 15)
    masks = {r: registration_mask(face, box, region=r) for r in ("face", "central", "rigid")}
    for mask in masks.values():
        assert mask.any() and not (mask & ~face).any()
        assert not mask[97:112, 74:103].any()  # the mouth box
        assert not mask[112:, 74:103].any()  # and the chin below it
    assert not (masks["central"] & ~masks["face"]).any()
    assert not (masks["rigid"] & ~masks["central"]).any()
    with pytest.raises(MiketalkError, match="unknown region"):
        registration_mask(face, box, region="eyes")  # type: ignore[arg-type]


def test_choose_reference_skips_an_odd_frame():
    for odd in range(4):  # wherever it is (a choice that ignored the frames would take it once)
        frames = np.stack([_head(2.0)] * 4)
        frames[odd] = _head(9.0)
        frames[odd, 40:60] = 0  # a frame unlike the others
        assert choose_reference(frames) != odd


# --- registration --------------------------------------------------------------------------


def _face_points(mask: np.ndarray) -> np.ndarray:
    ys, xs = np.nonzero(mask)
    return np.stack([xs, ys, np.ones_like(xs)]).astype(float)


def test_register_recovers_known_similarities():
    frames, truth = _clip()
    stab = Stabilizer.from_reference(frames[0], sample=frames)
    transforms = stab.register(frames, clip="synthetic")
    assert transforms.shape == (len(frames), 2, 3)
    points = _face_points(stab.mask)
    for k in range(len(frames)):
        error = np.hypot(*((transforms[k] - truth[k]) @ points))
        assert error.max() < 0.1, f"frame {k}: {error.max():.3f} px"
    assert (stab.correlations > 0.95).all()


def test_stabilize_brings_every_frame_onto_the_reference():
    frames, _ = _clip()
    stab = Stabilizer.from_reference(frames[0], sample=frames)
    result = stab.stabilize(frames, clip="synthetic")
    assert result.frames.shape == frames.shape and result.frames.dtype == np.uint8
    assert result.field is not None
    assert np.abs(result.field[stab.mask]).max() < 0.2  # nothing left for the field to do
    before = residual_motion(frames, frames[0], stab.mask)
    after = residual_motion(result.frames, frames[0], stab.mask)
    assert before.max() > 1.0 and after.max() < 0.15


def test_the_conform_field_takes_out_a_change_of_shape_the_similarity_cannot():
    """The test above leaves the field nothing to do (a field of zeros passes it): a face of
    another shape (wider at the brow and the chin, sheared), the same in every frame."""
    reference = _head(2.0)
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    u, v = (xx - 88) / 40, (yy - 70) / 52
    frame = cv2.remap(reference, xx + 1.5 * (v**2 - 0.3), yy + 1.2 * u * v, cv2.INTER_CUBIC,
                      borderMode=cv2.BORDER_REPLICATE)  # fmt: skip
    frames = np.stack([frame] * 6)
    stab = Stabilizer.from_reference(reference, sample=frames)
    result = stab.stabilize(frames)

    def error(stabilized: np.ndarray) -> float:  # grey levels from the reference, on the face
        return float(np.abs(stabilized.astype(float) - reference)[:, stab.mask].mean())

    # measured: 0.24 with the field, 0.70 with the similarity alone
    assert error(result.frames) < 0.5 * error(stab.apply(frames, result.transforms))


def test_a_frame_of_noise_does_not_register():
    frames, _ = _clip(3)
    stab = Stabilizer.from_reference(frames[0], mouth_box=(74, 97, 29, 15))
    noise = np.random.default_rng(5).integers(0, 256, frames[0].shape, dtype=np.uint8)
    with pytest.raises(MiketalkError, match=r"clip7 frame 1 does not register"):
        stab.register(np.stack([frames[1], noise, frames[2]]), clip="clip7")
    transforms = stab.register(np.stack([frames[1], noise, frames[2]]), on_failure="nan")
    assert np.isnan(transforms[1]).all() and np.isfinite(transforms[[0, 2]]).all()


def test_from_reference_needs_a_mouth_or_frames_to_find_it_in():
    with pytest.raises(MiketalkError, match="mouth_box"):
        Stabilizer.from_reference(_head(3.0))


def test_residual_motion_measures_a_shift():
    frame = _head(3.0)
    mask = locate_face(frame)
    shifted = cv2.warpAffine(frame, np.float64([[1, 0, 1.5], [0, 1, 0]]), (W, H),
                             borderMode=cv2.BORDER_REPLICATE)  # fmt: skip
    motion = residual_motion(np.stack([frame, shifted]), frame, mask)
    assert motion[0] < 0.01 and abs(motion[1] - 1.5) < 0.2


# --- frames around the speech that do not register (miketalk.corpus.steady) ----------------

FPS = 10.0


def _decoded(frames: np.ndarray, clip_id: str = "grey", **clip) -> DecodedClip:
    """``frames`` at 10 fps saying "ba" from 0.3 s to 0.9 s, with pauses either side."""
    n = len(frames)
    phones = (
        Phone("pau", 0.0, 0.3), Phone("b", 0.3, 0.5), Phone("aa", 0.5, 0.9),
        Phone("pau", 0.9, n / FPS),
    )  # fmt: skip
    samples = (np.arange(round(n / FPS * RATE)) % 251).astype(np.int16)
    return DecodedClip(
        Clip(clip_id, Path(f"{clip_id}.mp4"), "ba", **clip),
        frames, FPS, samples, phones, (WordTiming("ba", 0.3, 0.9),),
    )  # fmt: skip


def _greyed(frames: np.ndarray, which) -> np.ndarray:
    """``frames`` with the frames ``which`` plain grey, as an MPEG stream opens between key
    frames (GRID s1's bbizzn)."""
    out = frames.copy()
    out[list(which)] = 128
    return out


def test_speech_span_and_kept_frames():
    phones = _decoded(np.zeros((12, 2, 2, 3), np.uint8)).phones
    assert speech_span(phones, FPS, 12) == (3, 9)
    assert speech_span([Phone("pau", 0.0, 1.2)], FPS, 12) == (0, 12)
    assert kept_frames(np.array([0, 1, 10]), (3, 9), 12) == (2, 10)
    assert kept_frames(np.array([2, 11]), (3, 9), 12) == (3, 11)
    assert kept_frames(np.array([], int), (3, 9), 12) == (0, 12)


def test_cut_moves_the_sound_phones_and_words_with_the_first_frame_kept():
    decoded = _decoded(np.arange(12)[:, None, None, None].repeat(2, 1).astype(np.uint8))
    part = decoded.cut(2, 10)
    assert part.frames[:, 0, 0, 0].tolist() == list(range(2, 10))
    assert np.array_equal(part.samples, decoded.samples[round(0.2 * RATE) : round(1.0 * RATE)])
    assert [(p.name, round(p.start, 6), round(p.end, 6)) for p in part.phones] == [
        ("pau", 0.0, 0.1), ("b", 0.1, 0.3), ("aa", 0.3, 0.7), ("pau", 0.7, 0.8),
    ]  # fmt: skip
    assert [(w.word, round(w.start, 6), round(w.end, 6)) for w in part.words] == [("ba", 0.1, 0.7)]
    assert part.clip.span == (2, 8) and part.clip.start == pytest.approx(0.2)
    # a pause left without time goes; a part of a part knows where it is in the media
    again = part.cut(1, 8)
    assert again.phones[0].name == "b" and again.clip.span == (3, 7)
    spanned = _decoded(decoded.frames, span=(40, 12), fps=FPS,
                       given_words=(WordTiming("ba", 0.3, 0.9),)).cut(3, 9)  # fmt: skip
    assert spanned.clip.span == (43, 6)
    assert [(round(w.start, 6), round(w.end, 6)) for w in spanned.clip.given_words] == [(0.0, 0.6)]
    with pytest.raises(ValueError, match="cannot cut"):
        decoded.cut(5, 5)


def test_stabilize_clip_leaves_out_grey_frames_around_the_speech(caplog):
    frames, _ = _clip(12)
    stab = Stabilizer.from_reference(frames[0], mouth_box=(74, 97, 29, 15))
    whole, stabilized = stabilize_clip(_decoded(frames), stab)
    assert len(whole.frames) == 12 and len(stabilized.frames) == 12
    kept, stabilized = stabilize_clip(_decoded(_greyed(frames, [0, 1, 11])), stab)
    assert "clip grey: frames 0-1, 11 do not register" in caplog.text
    assert "its frames 2 to 10, around its speech, are kept" in caplog.text
    assert len(kept.frames) == 9 and kept.clip.span == (2, 9)
    assert np.array_equal(kept.frames, frames[2:11])
    assert np.array_equal(stabilized.frames, stab.stabilize(frames[2:11]).frames)
    assert (stabilized.correlations > 0.95).all() and len(stabilized.transforms) == 9
    assert kept.phones[0] == Phone("pau", 0.0, pytest.approx(0.1))
    with pytest.raises(ClipError, match=r"^clip grey frame 5 does not register .*, in its speech$"):
        stabilize_clip(_decoded(_greyed(frames, [0, 5])), stab)


def test_a_corpus_keeps_a_clip_whose_first_frames_are_grey(tmp_path):
    frames, _ = _clip(12)
    clips = {"steady": _decoded(frames, "steady"), "grey": _decoded(_greyed(frames, [0, 1]))}
    clips["holed"] = _decoded(_greyed(frames, [4]), "holed")
    done = ingest_clips(tmp_path, clips=[c.clip for c in clips.values()],
                        decode=lambda clip: clips[clip.id])  # fmt: skip
    assert done["clips"] == 2 and done["frames"] == 12 + 10 and done["skipped"] == 1
    table = (tmp_path / "clips.tsv").read_text().splitlines()
    assert [row.split("\t")[:3] for row in table[1:]] == [
        ["steady", "0", "12"],
        ["grey", "12", "10"],
    ]
    skipped = (tmp_path / "skipped.tsv").read_text().splitlines()[1:]
    assert len(skipped) == 1 and skipped[0].startswith(
        "holed\tclip holed frame 4 does not register"
    )
    phones = (tmp_path / "phones.tsv").read_text().splitlines()[1:]
    grey = [row.split("\t") for row in phones if row.startswith("grey\t")]
    assert [(p[2], p[3], p[5]) for p in grey[:2]] == [("pau", "1.200000", "0.000000"),
                                                      ("b", "1.300000", "0.100000")]  # fmt: skip


def test_a_part_of_a_video_left_out_is_named_by_the_videos_frames_and_seconds(tmp_path, caplog):
    """A build from one video cuts it into utterances: one left out was named by its id and
    its own frame number ("clip u0003.3 skipped: frame 1 is left out"), which a user cannot
    find in their video; now by the video's frames and seconds."""
    frames, _ = _clip(12)
    why = tuple("no frontal face" if k == 5 else None for k in range(12))
    holed = replace(_decoded(_greyed(frames, [5]), "u0003", span=(280, 12), fps=FPS),
                    left_out=why)  # fmt: skip
    clips = {"steady": _decoded(frames, "steady"), "u0003": holed}
    done = ingest_clips(tmp_path, clips=[c.clip for c in clips.values()],
                        decode=lambda clip: clips[clip.id])  # fmt: skip
    assert done["skipped"] == 1
    named = ("frames 280-291 of u0003.mp4 (28.00-29.20 s): frame 285 is left out (no frontal "
             "face), in its speech")  # fmt: skip
    assert (tmp_path / "skipped.tsv").read_text().splitlines()[1:] == [f"u0003\t{named}"]
    assert f"clip u0003 skipped: {named}" in caplog.text


def _spoken(frames: np.ndarray, left_out: dict[int, str], **clip) -> DecodedClip:
    """4 s at 10 fps: "bin blue" (0.3-1.6 s), "at" (1.8-2.2), "f" (2.2-2.6), "two" (2.6-3.4),
    the frames ``left_out`` flagged by the tracker."""
    phones = (
        Phone("pau", 0.0, 0.3), Phone("b", 0.3, 0.5), Phone("ih", 0.5, 0.7),
        Phone("n", 0.7, 0.9), Phone("b", 0.9, 1.1), Phone("l", 1.1, 1.3), Phone("uw", 1.3, 1.6),
        Phone("pau", 1.6, 1.8), Phone("ae", 1.8, 2.0), Phone("t", 2.0, 2.2), Phone("eh", 2.2, 2.4),
        Phone("f", 2.4, 2.6), Phone("t", 2.6, 2.9), Phone("uw", 2.9, 3.4), Phone("pau", 3.4, 4.0),
    )  # fmt: skip
    words = tuple(WordTiming(w, a, b) for w, a, b in [
        ("bin", 0.3, 0.9), ("blue", 0.9, 1.6), ("at", 1.8, 2.2), ("f", 2.2, 2.6), ("two", 2.6, 3.4),
    ])  # fmt: skip
    samples = (np.arange(4 * RATE) % 251).astype(np.int16)
    return DecodedClip(
        Clip("u0003", Path("u0003.mp4"), "bin blue at f two", **clip), frames, FPS, samples,
        phones, words, tuple(left_out.get(k) for k in range(len(frames))),
    )  # fmt: skip


def test_an_utterance_keeps_the_words_on_either_side_of_frames_left_out(tmp_path, caplog):
    """Frames the tracker left out in an utterance's speech (the head turned away, a second
    face) cost the whole utterance, 4.5 s of speech for 1.3 s of frames; now it is cut at
    its words: the words whose frames are tracked are kept, those over frames left out
    dropped and named by the video's frames and seconds, and a piece left too short too."""
    frames = np.concatenate([_clip(12)[0]] * 4)[:40]
    left_out = {19: "no frontal face", 20: "several faces", 21: "several faces",
                27: "no frontal face"}  # fmt: skip
    clips = {"u0003": _spoken(frames, left_out, span=(280, 40), fps=FPS)}
    done = ingest_clips(tmp_path, clips=[c.clip for c in clips.values()],
                        decode=lambda clip: clips[clip.id])  # fmt: skip
    table = (tmp_path / "clips.tsv").read_text().splitlines()[1:]
    assert [row.split("\t")[:3] for row in table] == [["u0003.1", "0", "18"]]
    assert table[0].split("\t")[5] == "bin blue"  # its own words
    words = json.loads((tmp_path / "words.json").read_text())["words"]
    assert [w["word"] for w in words] == ["bin", "blue"]
    skipped = (tmp_path / "skipped.tsv").read_text().splitlines()[1:]
    assert skipped == [
        "u0003.2\tframes 298-301 of u0003.mp4 (29.80-30.20 s): 1 word over frames left out "
        "(frame 299: no frontal face; frames 300-301: several faces): 'at'",
        "u0003.3\tframes 302-305 of u0003.mp4 (30.20-30.60 s): 1 word between frames left "
        "out, a piece of 4 frames (less than 0.6 s): 'f'",
        "u0003.4\tframes 306-313 of u0003.mp4 (30.60-31.40 s): 1 word over frames left out "
        "(frame 307: no frontal face): 'two'",
    ]
    assert done == {**done, "clips": 1, "frames": 18, "skipped": 3}
    assert "clip u0003.2 skipped: frames 298-301 of u0003.mp4 (29.80-30.20 s)" in caplog.text
    # the words after the frames left out are kept when long enough: a piece of their own
    clips = {"u0003": _spoken(frames, {k: left_out[k] for k in (19, 20, 21)}, span=(280, 40),
                              fps=FPS)}  # fmt: skip
    ingest_clips(tmp_path, clips=[c.clip for c in clips.values()],
                 decode=lambda clip: clips[clip.id])  # fmt: skip
    table = (tmp_path / "clips.tsv").read_text().splitlines()[1:]
    assert [row.split("\t")[:3] for row in table] == [["u0003.1", "0", "18"],
                                                      ["u0003.3", "18", "18"]]  # fmt: skip
    words = json.loads((tmp_path / "words.json").read_text())["words"]
    assert [(w["word"], w["clip"], round(w["start"], 6)) for w in words] == [
        ("bin", "u0003.1", 0.3), ("blue", "u0003.1", 0.9), ("f", "u0003.3", 1.8),
        ("two", "u0003.3", 2.2),
    ]  # fmt: skip
    phones = [r.split("\t") for r in (tmp_path / "phones.tsv").read_text().splitlines()[1:]]
    assert [p[2] for p in phones if p[0] == "u0003.3"] == ["eh", "f", "t", "uw", "pau"]
