"""Similarity transforms in the repository's 2x3 affine convention, and their parameters.

A transform is a ``(2, 3)`` float64 array ``T`` mapping a point ``(x, y)`` to
``T @ (x, y, 1)``; a track's transforms map frame pixel coordinates (a pixel's
centre at integer coordinates, as OpenCV and dlib place them) to canonical
coordinates (:mod:`~miketalk.track.canonical`).

:func:`fit_similarity` is the least-squares similarity between two point sets
(Umeyama's closed form, no reflection). :func:`pose_parameters` and
:func:`from_pose_parameters` turn a frame-to-canonical similarity into the four
numbers that are smoothed in time and back: the logarithm of the face's scale in
the frame (pixels per eye distance), the angle of its eye line (radians), and the
frame position of the canonical origin (the eyes' midpoint), all of the inverse
map (canonical to frame), where they are the face's size, roll and place.
"""

from __future__ import annotations

import numpy as np

from miketalk.errors import MiketalkError

__all__ = [
    "apply_affine",
    "compose_affine",
    "fit_similarity",
    "from_pose_parameters",
    "invert_affine",
    "pose_parameters",
    "similarity_scale",
]


def apply_affine(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map ``(..., 2)`` points by a ``(2, 3)`` affine transform.

    Parameters
    ----------
    transform : numpy.ndarray
        ``(2, 3)`` affine map.
    points : numpy.ndarray
        ``(..., 2)`` points ``(x, y)``.

    Returns
    -------
    numpy.ndarray
        ``(..., 2)`` float64 mapped points.
    """
    t = np.asarray(transform, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    return p @ t[:, :2].T + t[:, 2]


def invert_affine(transform: np.ndarray) -> np.ndarray:
    """The inverse of a ``(2, 3)`` affine transform.

    Raises
    ------
    MiketalkError
        If the transform is singular.
    """
    t = np.asarray(transform, dtype=np.float64)
    linear = t[:, :2]
    det = float(np.linalg.det(linear))
    if not np.isfinite(det) or abs(det) < 1e-12:
        raise MiketalkError(f"the affine transform {t.tolist()} is singular")
    inverse = np.linalg.inv(linear)
    return np.hstack([inverse, -(inverse @ t[:, 2:3])])


def compose_affine(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The ``(2, 3)`` transform applying ``inner`` first, then ``outer``."""
    a = np.asarray(outer, dtype=np.float64)
    b = np.asarray(inner, dtype=np.float64)
    return np.hstack([a[:, :2] @ b[:, :2], a[:, :2] @ b[:, 2:3] + a[:, 2:3]])


def similarity_scale(transform: np.ndarray) -> float:
    """The scale of an affine transform: the square root of its linear part's determinant."""
    t = np.asarray(transform, dtype=np.float64)
    return float(np.sqrt(abs(np.linalg.det(t[:, :2]))))


def fit_similarity(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The least-squares similarity mapping ``source`` points onto ``target`` points.

    Minimizes ``sum |s R p + t - q|^2`` over the scale ``s > 0``, the rotation ``R``
    (no reflection) and the translation ``t`` (Umeyama 1991).

    Parameters
    ----------
    source, target : numpy.ndarray
        ``(n, 2)`` corresponding points, ``n >= 2``, the source points not all equal.

    Returns
    -------
    numpy.ndarray
        ``(2, 3)`` float64 transform mapping source coordinates to target coordinates.

    Raises
    ------
    MiketalkError
        If the point sets differ in shape, have fewer than two points or are not finite,
        or the source points coincide.
    """
    p = np.asarray(source, dtype=np.float64)
    q = np.asarray(target, dtype=np.float64)
    if p.shape != q.shape or p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
        raise MiketalkError(f"fit_similarity needs two (n, 2) point sets, got {p.shape}, {q.shape}")
    if not (np.isfinite(p).all() and np.isfinite(q).all()):
        raise MiketalkError("fit_similarity: the points are not all finite")
    mp, mq = p.mean(axis=0), q.mean(axis=0)
    pc, qc = p - mp, q - mq
    variance = float((pc**2).sum())
    if variance < 1e-18:
        raise MiketalkError("fit_similarity: the source points coincide")
    # with complex numbers z = x + iy, the best s R is a = sum(conj(p) q) / sum(|p|^2)
    a = float((pc[:, 0] * qc[:, 0] + pc[:, 1] * qc[:, 1]).sum()) / variance
    b = float((pc[:, 0] * qc[:, 1] - pc[:, 1] * qc[:, 0]).sum()) / variance
    linear = np.array([[a, -b], [b, a]])
    return np.hstack([linear, (mq - linear @ mp)[:, None]])


def pose_parameters(transform: np.ndarray) -> np.ndarray:
    """A frame-to-canonical similarity's pose: ``(log scale, angle, x, y)``.

    Parameters
    ----------
    transform : numpy.ndarray
        ``(2, 3)`` similarity, frame to canonical coordinates (or ``(N, 2, 3)``).

    Returns
    -------
    numpy.ndarray
        ``(4,)`` (or ``(N, 4)``): the natural logarithm of the face's eye distance in
        frame pixels, the eye line's angle in the frame (radians, counter-clockwise in
        the image's x-right, y-down axes), and the frame position ``(x, y)`` of the
        canonical origin.
    """
    t = np.asarray(transform, dtype=np.float64)
    a, b = t[..., 0, 0], t[..., 1, 0]
    k = a * a + b * b  # the inverse's linear part is [[a, b], [-b, a]] / k
    scale = 1.0 / np.sqrt(k)
    angle = np.arctan2(-b, a)
    tx, ty = t[..., 0, 2], t[..., 1, 2]
    x = -(a * tx + b * ty) / k
    y = -(-b * tx + a * ty) / k
    return np.stack([np.log(scale), angle, x, y], axis=-1)


def from_pose_parameters(parameters: np.ndarray) -> np.ndarray:
    """The frame-to-canonical similarity of a pose (the inverse of :func:`pose_parameters`).

    Parameters
    ----------
    parameters : numpy.ndarray
        ``(4,)`` or ``(N, 4)``: log scale, angle, x, y.

    Returns
    -------
    numpy.ndarray
        ``(2, 3)`` or ``(N, 2, 3)`` float64.
    """
    p = np.asarray(parameters, dtype=np.float64)
    inv_scale = np.exp(-p[..., 0])
    c, s = np.cos(p[..., 1]) * inv_scale, np.sin(p[..., 1]) * inv_scale
    x, y = p[..., 2], p[..., 3]
    out = np.empty((*p.shape[:-1], 2, 3))
    # canonical = R(-angle) (frame - origin) / scale
    out[..., 0, 0], out[..., 0, 1] = c, s
    out[..., 1, 0], out[..., 1, 1] = -s, c
    out[..., 0, 2] = -(c * x + s * y)
    out[..., 1, 2] = -(-s * x + c * y)
    return out
