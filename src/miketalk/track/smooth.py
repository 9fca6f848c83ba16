"""Smoothing a track's per-frame transforms in time: less jitter, no lag, no glitch.

Each frame's transform is reduced to its pose (:func:`~miketalk.track.similarity.pose_parameters`:
log scale, roll angle, the eyes' midpoint ``x, y`` in the frame), and the four series are
smoothed within each *segment* (a run of consecutive frames of one shot) separately,
never across a gap or a cut:

1. **Glitches**: a frame whose pose is far from what the two frames either side of it
   predict (the cubic through them: a real move, even a fast nod, predicts itself; a spike
   of one or two frames, a landmark caught on a hand, does not) is an outlier, and its
   pose is replaced by the prediction. Far: its face points are more than
   ``outlier_factor`` times the segment's median such distance away, and at least
   ``min_outlier`` eye distances (0.1: GRID's clips hold real one-frame jolts of 0.05).
2. **Adaptive smoothing** (local polynomial regression with the *intersection of
   confidence intervals* rule, Katkovnik 1999): each series is fitted at each frame by
   local quadratics with Gaussian weights of several widths (:data:`WIDTHS` times
   ``sigma``, the first 0: the frame's own value), each with its standard deviation (the
   series' noise, from the median absolute fourth difference, times the fit's noise
   gain). Per frame the widest fit is kept whose confidence interval (``gamma``
   standard deviations) still meets every narrower one's: where the face is still or
   moves smoothly, the widest (the most jitter removed); where it moves fast (a nod),
   a narrow one, so the smoothed face does not lag behind the real one.

Both are linear in the frames but the choice of width: the result is the same for the
same input, and a segment of a few frames is left nearly as it is.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.track.similarity import from_pose_parameters, pose_parameters

__all__ = ["WIDTHS", "local_quadratic", "smooth_poses", "smooth_series", "smooth_transforms"]

#: The fits' Gaussian widths, as fractions of ``sigma`` (0: the frame's own value).
WIDTHS = (0.0, 0.25, 0.5, 0.75, 1.0)
_RIDGE = 1e-6  # keeps a segment of one or two frames solvable (slope and curvature to 0)
_GLITCH_ROUNDS = 3


def local_quadratic(values: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Local quadratic regression of series with a Gaussian kernel, and its noise gain.

    Parameters
    ----------
    values : numpy.ndarray
        ``(n, k)``: ``k`` series of ``n`` evenly spaced samples.
    sigma : float
        The kernel's standard deviation in samples (0: no smoothing).

    Returns
    -------
    fitted : numpy.ndarray
        ``(n, k)``: at each sample, the value there of the quadratic fitted to the
        samples around it (at a series' ends, to those there are).
    gain : numpy.ndarray
        ``(n,)``: the fit's standard deviation per unit of white noise in the samples
        (1 for ``sigma`` 0).
    """
    y = np.asarray(values, dtype=np.float64)
    n = y.shape[0]
    if sigma <= 0 or n == 0:
        return y.copy(), np.ones(n)
    radius = min(int(np.ceil(3 * sigma)), n - 1)
    d = np.arange(-radius, radius + 1, dtype=np.float64)
    kernel = np.exp(-0.5 * (d / sigma) ** 2)
    ones = np.ones(n)

    def correlate(signal: np.ndarray, weights: np.ndarray, power: int) -> np.ndarray:
        # sum_j weights(j - i) (j - i)^power signal_j, for every i
        full = np.convolve(signal, (weights * d**power)[::-1], mode="full")
        return full[radius : radius + n]

    def moments(weights: np.ndarray) -> np.ndarray:
        m = [correlate(ones, weights, p) for p in range(5)]
        out = np.empty((n, 3, 3))
        for r in range(3):
            for c in range(3):
                out[:, r, c] = m[r + c]
        return out

    a = moments(kernel)
    a[:, 1, 1] += _RIDGE * a[:, 0, 0]
    a[:, 2, 2] += _RIDGE * a[:, 0, 0]
    inverse = np.linalg.inv(a)
    # the fit at i is e1' A^-1 sum_j K (1, d, d^2)' y_j: its noise variance e1' A^-1 B A^-1 e1
    b = moments(kernel**2)
    first = inverse[:, 0, :]
    gain = np.sqrt(np.maximum(np.einsum("ni,nij,nj->n", first, b, first), 0.0))
    fitted = np.empty_like(y)
    for k in range(y.shape[1]):
        rhs = np.stack([correlate(y[:, k], kernel, p) for p in range(3)], axis=1)
        fitted[:, k] = np.einsum("ni,ni->n", first, rhs)
    return fitted, gain


def _noise(series: np.ndarray) -> float:
    """White noise's standard deviation in a series, from its fourth differences (robust).

    A fourth difference is blind to a cubic's trend and shrinks a move of ``T`` frames'
    period by ``(2 sin(pi / T))^4`` (a head's nod of 20 frames: 0.01), while it multiplies
    white noise's variance by 70; the median absolute deviation ignores the few frames
    of a sudden start or stop.
    """
    if series.size < 9:
        return 0.0
    fourth = np.diff(series, n=4)
    return float(1.4826 * np.median(np.abs(fourth - np.median(fourth))) / np.sqrt(70.0))


def smooth_series(values: np.ndarray, sigma: float, *, gamma: float = 2.0) -> np.ndarray:
    """Adaptive smoothing of series (local quadratics, intersection of confidence intervals).

    Parameters
    ----------
    values : numpy.ndarray
        ``(n, k)`` evenly spaced samples of ``k`` series.
    sigma : float
        The widest fit's Gaussian standard deviation, in samples.
    gamma : float
        The confidence intervals' half-width, in standard deviations.

    Returns
    -------
    numpy.ndarray
        ``(n, k)``.
    """
    y = np.asarray(values, dtype=np.float64)
    if sigma <= 0 or y.shape[0] < 5:
        return y.copy()
    fits = [local_quadratic(y, w * sigma) for w in WIDTHS]
    out = y.copy()
    for k in range(y.shape[1]):
        noise = _noise(y[:, k])
        if noise <= 0.0:
            out[:, k] = fits[-1][0][:, k]
            continue
        low = np.full(y.shape[0], -np.inf)
        high = np.full(y.shape[0], np.inf)
        alive = np.ones(y.shape[0], dtype=bool)
        for fitted, gain in fits:
            half = gamma * noise * gain
            low = np.maximum(low, fitted[:, k] - half)
            high = np.minimum(high, fitted[:, k] + half)
            alive &= low <= high
            out[alive, k] = fitted[alive, k]
    return out


def _glitches(poses: np.ndarray, factor: float, floor: float) -> tuple[np.ndarray, np.ndarray]:
    """Glitch frames and the poses with them replaced by their neighbours' prediction.

    Each frame's pose is predicted from the two frames either side by the cubic through
    them, ``(-p[i-2] + 4 p[i-1] + 4 p[i+1] - p[i+2]) / 6`` (exact for any cubic move, so a
    fast nod predicts itself); a frame whose distance from its prediction exceeds
    ``max(factor * median, floor)`` and is the largest within two frames is a glitch and
    takes its prediction, and again (a glitch of two frames) up to :data:`_GLITCH_ROUNDS`
    times. The first and last two frames of a segment are not checked.
    """
    q = poses.copy()
    outliers = np.zeros(q.shape[0], dtype=bool)
    if q.shape[0] < 5:
        return q, outliers
    threshold = None
    for _ in range(_GLITCH_ROUNDS):
        predicted = (-q[:-4] + 4 * q[1:-3] + 4 * q[3:-1] - q[4:]) / 6
        distance = _distance(q[2:-2], predicted)
        if threshold is None:
            threshold = max(factor * float(np.median(distance)), floor)
        padded = np.pad(distance, 2, constant_values=-np.inf)
        local_max = np.max(np.lib.stride_tricks.sliding_window_view(padded, 5), axis=1)
        bad = (distance > threshold) & (distance >= local_max)
        if not bad.any():
            break
        q[2:-2][bad] = predicted[bad]
        outliers[2:-2] |= bad
    return q, outliers


def _distance(poses: np.ndarray, others: np.ndarray) -> np.ndarray:
    """How far the face points of one pose are from another's, in eye distances (roughly:
    the log scale's and the angle's differences count as such, the position's divided by
    the eye distance)."""
    diff = poses - others
    eye_distance = np.exp(others[:, 0])
    return np.sqrt(
        diff[:, 0] ** 2 + diff[:, 1] ** 2 + (diff[:, 2] ** 2 + diff[:, 3] ** 2) / eye_distance**2
    )


def smooth_poses(
    poses: np.ndarray,
    *,
    sigma: float,
    gamma: float = 2.0,
    outlier_factor: float = 6.0,
    min_outlier: float = 0.1,
) -> tuple[np.ndarray, np.ndarray]:
    """Smooth one segment's poses: glitches replaced, then adaptive smoothing.

    Parameters
    ----------
    poses : numpy.ndarray
        ``(n, 4)`` log scale, angle, x, y of consecutive frames of one shot (finite).
    sigma : float
        The widest smoothing's Gaussian standard deviation, in frames.
    gamma : float
        The confidence intervals' half-width, in standard deviations.
    outlier_factor : float
        A frame is a glitch beyond this many times the segment's median distance from
        its neighbours' prediction...
    min_outlier : float
        ... and beyond this many eye distances.

    Returns
    -------
    smoothed : numpy.ndarray
        ``(n, 4)``.
    outliers : numpy.ndarray
        ``(n,)`` bool: the glitches.
    """
    p = np.asarray(poses, dtype=np.float64).copy()
    p[:, 1] = np.unwrap(p[:, 1])
    p, outliers = _glitches(p, outlier_factor, min_outlier)
    return smooth_series(p, sigma, gamma=gamma), outliers


def smooth_transforms(
    transforms: np.ndarray,
    segments: Sequence[tuple[int, int]],
    *,
    sigma: float,
    gamma: float = 2.0,
    outlier_factor: float = 6.0,
    min_outlier: float = 0.1,
) -> tuple[np.ndarray, np.ndarray]:
    """Smooth frame-to-canonical similarities within each segment.

    Parameters
    ----------
    transforms : numpy.ndarray
        ``(N, 2, 3)``; frames outside every segment are ignored (NaN allowed there).
    segments : sequence of (int, int)
        ``[start, stop)`` frame ranges, disjoint: each smoothed on its own.
    sigma, gamma, outlier_factor, min_outlier : float
        As :func:`smooth_poses`.

    Returns
    -------
    smoothed : numpy.ndarray
        ``(N, 2, 3)``: smoothed in the segments, NaN elsewhere.
    outliers : numpy.ndarray
        ``(N,)`` bool.

    Raises
    ------
    MiketalkError
        If a segment is out of range or holds a transform that is not finite.
    """
    t = np.asarray(transforms, dtype=np.float64)
    out = np.full_like(t, np.nan)
    outliers = np.zeros(t.shape[0], dtype=bool)
    for start, stop in segments:
        if not 0 <= start < stop <= t.shape[0]:
            raise MiketalkError(f"segment [{start}, {stop}) is outside 0..{t.shape[0]}")
        part = t[start:stop]
        if not np.isfinite(part).all():
            raise MiketalkError(f"segment [{start}, {stop}) holds a transform that is not finite")
        smoothed, bad = smooth_poses(
            pose_parameters(part),
            sigma=sigma,
            gamma=gamma,
            outlier_factor=outlier_factor,
            min_outlier=min_outlier,
        )
        out[start:stop] = from_pose_parameters(smoothed)
        outliers[start:stop] = bad
    return out, outliers
