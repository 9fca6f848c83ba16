"""What tracking a face through a video gives: per frame a transform or why it was left out."""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Failure", "FailureRange", "Track", "failure_ranges"]


class Failure(enum.StrEnum):
    """Why a frame is left out of a track."""

    NO_FACE = "no frontal face"
    SEVERAL_FACES = "several faces"
    POOR_FIT = "landmarks do not fit a frontal face"


@dataclass(frozen=True)
class FailureRange:
    """Frames ``[start, stop)`` left out for one reason."""

    start: int
    stop: int
    reason: Failure | str

    def __str__(self) -> str:
        last = self.stop - 1
        frames = f"frame {self.start}" if last == self.start else f"frames {self.start}-{last}"
        return f"{frames}: {self.reason}"


def failure_ranges(reasons: Sequence[Failure | str | None], start: int = 0) -> list[FailureRange]:
    """Per-frame reasons (None: tracked) as ranges of consecutive frames left out for one
    reason, the first frame numbered ``start`` (a part of a longer video: its first frame's
    number in the video)."""
    out: list[FailureRange] = []
    for i, reason in enumerate(reasons, start):
        if reason is None:
            continue
        if out and out[-1].stop == i and out[-1].reason == reason:
            out[-1] = FailureRange(out[-1].start, i + 1, reason)
        else:
            out.append(FailureRange(i, i + 1, reason))
    return out


@dataclass(frozen=True)
class Track:
    """A face tracked through the frames of a video.

    Attributes
    ----------
    transforms : numpy.ndarray
        ``(N, 2, 3)`` float64 frame-to-canonical similarities, smoothed; NaN where the
        frame is left out.
    raw : numpy.ndarray
        ``(N, 2, 3)`` the per-frame fits before smoothing (NaN where left out).
    landmarks : numpy.ndarray
        ``(N, 5, 2)`` the five landmarks found, frame pixels (NaN where left out).
    fit_error : numpy.ndarray
        ``(N,)`` the landmarks' RMS distance from the canonical ones, eye distances.
    face_score : numpy.ndarray
        ``(N,)`` the detector's score on the face's patch (``-inf``: none).
    reasons : tuple of (Failure or None)
        Per frame, why it is left out (None: tracked).
    segments : tuple of (int, int)
        ``[start, stop)`` runs of tracked frames of one shot, smoothed separately.
    outliers : numpy.ndarray
        ``(N,)`` bool: tracked frames whose fit the smoothing overruled.
    fps : float
        The frames' rate.
    size : tuple of int
        The frames' ``(width, height)``.
    """

    transforms: np.ndarray
    raw: np.ndarray
    landmarks: np.ndarray
    fit_error: np.ndarray
    face_score: np.ndarray
    reasons: tuple[Failure | None, ...]
    segments: tuple[tuple[int, int], ...]
    outliers: np.ndarray
    fps: float
    size: tuple[int, int]

    def __len__(self) -> int:
        return len(self.reasons)

    @property
    def tracked(self) -> np.ndarray:
        """``(N,)`` bool: the frames with a transform."""
        return np.array([r is None for r in self.reasons], dtype=bool)

    def transform(self, index: int) -> np.ndarray | None:
        """Frame ``index``'s smoothed frame-to-canonical transform, or None if left out."""
        if self.reasons[index] is not None:
            return None
        return self.transforms[index].copy()

    def failures(self) -> list[FailureRange]:
        """The frames left out, as ranges of consecutive frames with one reason."""
        return failure_ranges(self.reasons)

    def cuts(self) -> list[int]:
        """Frames that start a new segment right after another one (a shot change or a jump)."""
        return [start for (start, _), (_, stop) in zip(self.segments[1:], self.segments[:-1],
                                                       strict=True) if start == stop]  # fmt: skip

    def summary(self) -> str:
        """One paragraph: frames tracked, segments, cuts, failures."""
        n, ok = len(self), int(self.tracked.sum())
        lines = [
            f"{ok} of {n} frames tracked in {len(self.segments)} segment(s); "
            f"cuts at {self.cuts() or 'none'}; {int(self.outliers.sum())} outlier fit(s) "
            "smoothed over"
        ]
        lines += [f"  left out: {f}" for f in self.failures()]
        return "\n".join(lines)
