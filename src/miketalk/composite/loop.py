"""The background's loop in time: ping-pong, where it turns, and its transforms smoothed.

A background sequence plays forwards, then backwards, then forwards again
(:func:`pingpong`): a frame is always followed by one of its neighbours. Where the
loop turns the head's motion turns round, unseen where the head stands still:
:func:`still_window` cuts the sequence there, by the speed :func:`head_speed` measures
from the frames' stabilization transforms. :func:`smooth_in_time` smooths those
transforms, whose per-frame registration error would slide the mouth against the nose.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

__all__ = ["head_speed", "pingpong", "smooth_in_time", "still_window"]


def pingpong(i: int, n: int) -> int:
    """Frame ``i`` of ``0, 1, ..., n-1, n-2, ..., 1, 0, 1, ...``: a loop without a jump."""
    if n <= 1:
        return 0
    period = 2 * (n - 1)
    m = i % period
    return m if m < n else period - m


def head_speed(transforms: np.ndarray, point: tuple[float, float]) -> np.ndarray:
    """How fast a reference ``point`` moves in the frames, px per frame ((N,), central differences).

    The point is carried by each frame's transform (``T @ (x, y, 1)``): the head's motion
    there, not the mouth's.
    """
    t = np.asarray(transforms, np.float64)
    where = t[:, :, :2] @ np.asarray(point, np.float64) + t[:, :, 2]
    if len(where) < 2:
        return np.zeros(len(where))
    return np.linalg.norm(np.gradient(where, axis=0), axis=1)


def still_window(
    speed: np.ndarray,
    blinks: Iterable[int],
    *,
    shortest: int,
    longest: int,
    shot: np.ndarray | None = None,
) -> tuple[int, int]:
    """The frames ``[start, stop)`` to play ping-pong: both turns where the head is still.

    A ping-pong loop turns the head's motion round at its first and last frames; where
    the head stands still the turn cannot be seen. Among the windows of ``shortest`` to
    ``longest`` frames that keep a blink (when the frames have one), the one whose two
    ends move least (``speed[start] + speed[stop - 1]``; the longer on a tie, then the
    earlier).

    Parameters
    ----------
    speed : numpy.ndarray
        (N,) the head's speed per frame (:func:`head_speed`).
    blinks : iterable of int
        Frames where the eyes close.
    shortest, longest : int
        The window's least and greatest length, frames (clipped to ``N``).
    shot : numpy.ndarray, optional
        (N,) int: the shot each frame belongs to, -1 for a frame that may not be played
        (no face tracked): a window lies within one shot. None: all one.
    """
    n = len(speed)
    longest = max(1, min(longest, n))
    shortest = max(1, min(shortest, longest))
    marks = np.zeros(n + 1, int)
    for b in blinks:
        if 0 <= b < n:
            marks[b + 1] = 1
    seen = np.cumsum(marks)  # blinks before each frame
    need = bool(seen[-1])
    best = None
    for start in range(n - shortest + 1):
        for stop in range(start + shortest, min(n, start + longest) + 1):
            if need and seen[stop] == seen[start]:
                continue
            if shot is not None and (shot[start] < 0 or shot[start] != shot[stop - 1]):
                continue
            key = (round(float(speed[start] + speed[stop - 1]), 6), -(stop - start), start)
            if best is None or key < best[0]:
                best = (key, start, stop)
    return (0, longest) if best is None else (best[1], best[2])


def smooth_in_time(transforms: np.ndarray, sigma: float) -> np.ndarray:
    """``transforms`` (N, 2, 3) convolved in time with a Gaussian of ``sigma`` frames.

    The ends are extended by repeating the first and last transform (``mode="nearest"``).
    """
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(np.asarray(transforms, np.float64), sigma, axis=0, mode="nearest")
