"""The face tracked in two halves at once (:mod:`miketalk.track.halves`): joined as one run's."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.media.decode import iter_video_frames, read_video
from miketalk.media.video import write_mp4
from miketalk.track import apply_affine, invert_affine, track_frames
from miketalk.track.canonical import CANONICAL_LANDMARKS
from miketalk.track.halves import SHORTEST, track_in_halves

CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"
N = SHORTEST + 10


def _video(path: Path, shift) -> Path:
    """N frames of s1's clip (played forwards, then backwards) slid across a wider frame by
    ``shift(k)`` pixels (lossless)."""
    clip, _ = read_video(CLIP)
    frames = [clip[k if k < len(clip) else 2 * len(clip) - 2 - k] for k in range(N)]
    moved = []
    for k, frame in enumerate(frames):
        m = np.array([[1.0, 0.0, 20.0 + shift(k)], [0.0, 1.0, 10.0]])
        moved.append(cv2.warpAffine(frame, m, (480, 300), borderMode=cv2.BORDER_REPLICATE))
    write_mp4(path, moved, fps=25, n_frames=N, crf=0)
    return path


def _points(transform: np.ndarray) -> np.ndarray:
    return apply_affine(invert_affine(transform), CANONICAL_LANDMARKS)


@pytest.mark.parametrize(
    ("shift", "segments"),
    [
        (lambda k: 0.3 * k, ((0, N),)),  # a slow slide: one segment across the join
        (lambda k: 0.0 if k < N // 2 else 90.0, ((0, N // 2), (N // 2, N))),  # a jump cut there
    ],
    ids=["one shot", "a cut at the join"],
)
def test_two_halves_track_as_one_run(tmp_path, shift, segments):
    path = _video(tmp_path / "v.mp4", shift)
    one = track_frames(iter_video_frames(path, grey=True), fps=25.0)
    halves = track_in_halves(path, fps=25.0)
    assert len(halves) == len(one) == N and halves.tracked.all()
    assert halves.segments == one.segments == segments
    worst = max(
        np.abs(_points(a) - _points(b)).max()
        for a, b in zip(halves.transforms, one.transforms, strict=True)
    )
    assert worst < 1.0  # pixels: the second half's first frames start from a detection
    # the first half is one run's own, but for the smoothing's reach across the join
    far = slice(0, N // 2 - 10)
    np.testing.assert_array_equal(halves.raw[far], one.raw[far])


def test_a_short_video_is_tracked_in_one_run(tmp_path):
    frames, _ = read_video(CLIP, frames=30)
    path = tmp_path / "short.mp4"
    write_mp4(path, list(frames), fps=25, n_frames=30, crf=0)
    one = track_frames(iter_video_frames(path, grey=True), fps=25.0)
    halves = track_in_halves(path, fps=25.0)
    np.testing.assert_array_equal(halves.transforms, one.transforms)
