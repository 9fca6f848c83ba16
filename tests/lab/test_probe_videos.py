"""The bad-input probes: how each spoils a video, and the checks of what a run left.

Small frames, and one GRID clip of the repository (``data/grid_s1``) for the tracked
geometry and a probe written as an mp4.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio, read_video
from miketalk.track import track_frames
from miketalk_lab.bench.probe_checks import (
    changed_pixels,
    leftovers,
    named_frames,
    ranges,
    stderr_lines,
)
from miketalk_lab.probe_videos import (
    HEAD_HALF_DEPTH,
    HEAD_ROWS,
    PROBES,
    face_geometry,
    probe_frame,
    rolled,
    shifted,
    side_by_side,
    span_weights,
    with_second_face,
    write_probe,
    yaw_turned,
)

CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"


def _columns(height: int = 120, width: int = 160) -> np.ndarray:
    """A frame whose red channel is its column and green its row."""
    frame = np.zeros((height, width, 3), np.uint8)
    frame[..., 0] = np.arange(width)[None, :]
    frame[..., 1] = np.arange(height)[:, None]
    return frame


def test_a_span_changes_its_frames_only_ramping_in_and_out():
    w = span_weights(40, (10, 30), ramp=4)
    assert (w[:10] == 0).all() and (w[30:] == 0).all() and (w[10:30] > 0).all()
    assert w[10] == pytest.approx(0.2) and w[29] == pytest.approx(0.2) and w[20] == 1.0
    assert (span_weights(5, None) == 1).all()
    with pytest.raises(MiketalkError, match="not inside"):
        span_weights(20, (10, 30))


def test_leaving_slides_the_picture_out_and_fills_with_its_mean():
    frame = _columns()
    assert np.array_equal(shifted(frame, 0.0), frame)
    half = shifted(frame, 0.5)
    assert np.array_equal(half[:, :80], frame[:, 80:])
    assert (half[:, 80:] == frame.reshape(-1, 3).mean(axis=0).astype(np.uint8)).all()


def test_a_turn_is_a_yaw_of_the_head_rows_and_moves_the_face_to_its_silhouette():
    frame = _columns()
    x0, y0, d = 80.0, 50.0, 20.0
    assert np.abs(yaw_turned(frame, (x0, y0, d), 0.0).astype(int) - frame).max() <= 1
    turned = yaw_turned(frame, (x0, y0, d), 75.0)
    rows = np.arange(frame.shape[0])
    outside = (rows < y0 + HEAD_ROWS[0] * d) | (rows > y0 + HEAD_ROWS[3] * d)
    assert np.array_equal(turned[outside], frame[outside])  # above and below the head
    eyes = turned[round(y0), :, 0].astype(float)  # where each column of a head row came from
    assert (np.diff(eyes) >= -1).all()  # no fold
    centre = int(np.argmin(np.abs(eyes - x0)))  # where the face's middle shows now
    assert centre - x0 == pytest.approx(HEAD_HALF_DEPTH * d * math.sin(math.radians(75)), abs=2)
    theta = math.radians(75)
    half = d * math.hypot(math.cos(theta), HEAD_HALF_DEPTH * math.sin(theta))  # silhouette
    inside = eyes[math.ceil(x0 - half) : math.floor(x0 + half)]
    assert inside.max() < x0 + 0.3 * d  # the far cheek is hidden past the silhouette
    assert (inside[: round(half) - 5] <= x0 - d + 1).all()  # the near side: its edge stretched


def test_roll_two_faces_and_a_second_face_keep_the_frames_size():
    frame, other = _columns(), _columns()[::-1].copy()
    for made in (rolled(frame), side_by_side(frame, other)):
        assert made.shape == frame.shape
    assert np.array_equal(side_by_side(frame, other)[:, :80], frame[:, 40:120])
    assert np.array_equal(with_second_face(frame, other, (50, 60, 10), (80, 60, 10), 0.0), frame)
    pasted = with_second_face(frame, other, (50, 60, 10), (80, 60, 10), 1.0)
    changed = np.flatnonzero((pasted != frame).any(axis=(0, 2)))
    assert changed.min() > 50 + 10  # beside the face, not on it
    with pytest.raises(MiketalkError, match="no probe"):
        probe_frame("sideways", frame, 1.0, (50, 60, 10))
    with pytest.raises(MiketalkError, match="other face"):
        probe_frame("two", frame, 1.0, (50, 60, 10))


def test_a_probe_is_written_with_the_sound_and_changes_its_span_only(tmp_path):
    frames, fps = read_video(CLIP, frames=24)
    geometry = face_geometry(track_frames(frames, fps=fps))
    assert geometry.shape == (24, 3) and 30 < geometry[:, 2].mean() < 60  # s1's eye distance
    audio = read_media_audio(CLIP, rate=16000)[: round(24 / fps * 16000)]
    out = tmp_path / "turn.mp4"
    weights = write_probe(out, "turn", lambda: iter(frames), geometry, fps=fps, audio=audio,
                          rate=16000, span=(8, 16), crf=0)  # fmt: skip
    assert np.flatnonzero(weights).tolist() == list(range(8, 16))
    made, _ = read_video(out)
    assert len(made) == 24 and len(read_media_audio(out, rate=16000)) > 0.9 * len(audio)
    grey = [f.mean(axis=2) for f in made]
    source = [f.mean(axis=2) for f in frames]
    moved = [changed_pixels(a.astype(np.uint8), b.astype(np.uint8))
             for a, b in zip(source, grey, strict=True)]  # fmt: skip
    assert max(moved[:8] + moved[16:]) < 20 < min(moved[10:14])
    for name in PROBES:  # every probe makes a frame of the source's size
        made = probe_frame(name, frames[12], 1.0, geometry[12], other=frames[0],
                           other_geometry=geometry[0])  # fmt: skip
        assert made.shape == frames[12].shape


def test_the_checks_read_what_a_run_left(tmp_path):
    line = (
        "miketalk: WARNING: v.mp4: 45 of its 400 frames show no one frontal face and play "
        "without a new mouth (frames 20-64: no frontal face; frame 70: several faces)"
    )
    assert named_frames([line, "miketalk: WARNING: frame 3: else"]) == {*range(20, 65), 70}
    assert ranges({3, 1, 2, 7, 9, 10}) == "1-3, 7, 9-10" and ranges([]) == ""
    lines, traceback = stderr_lines("miketalk build: stage: 1 s\nmiketalk: error: no face\n")
    assert lines == ["miketalk: error: no face"] and not traceback
    lines, traceback = stderr_lines("Traceback (most recent call last):\n  x\nValueError: y\n")
    assert traceback and lines == ["ValueError: y"]
    still = np.full((60, 80), 100, np.uint8)
    noisy, mouth = still.copy(), still.copy()
    noisy[::6, ::5] += 40  # a re-encoding's scattered error
    noisy[30, :] += 30  # and along a sharp edge
    mouth[20:40, 30:55] += 30  # a mouth drawn
    assert changed_pixels(still, noisy) == 0 and changed_pixels(still, mouth) > 300
    (tmp_path / "tmp").mkdir()
    for name in ("dub.mp4", "dub.json", "stderr.txt", ".dub.mp4.part", "tmp/x"):
        (tmp_path / name).write_text("")
    assert leftovers(tmp_path, {"dub.mp4", "dub.json"}) == (
        ["dub.json", "dub.mp4"], [".dub.mp4.part", "tmp/x"])  # fmt: skip
