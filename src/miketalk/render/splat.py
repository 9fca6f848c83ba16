"""Forward warping (paper Eq. 3-6, Fig. 6): every source pixel pushed along its flow.

One entry, :func:`forward_warp`, with its collision rule and splat named
(``collision``: ``"motion"`` or ``"scan"``; ``splat``: ``"nearest"`` or
``"bilinear"``; see :mod:`miketalk.render.morph` for the rules), and the hole
policy: holes hold :data:`HOLE_VALUE` until :func:`fill_holes_scanline` fills them.

Bilinear splatting (an option, not the paper's)
-----------------------------------------------
``splat="bilinear"`` replaces stage 1's rounding: every source pixel is spread
over the four destination pixels around its exact landing point
``p + alpha * C0(p)`` with bilinear weights, and each destination pixel gets
the weighted mean of what landed on it. Colliding sources are averaged by
their weights, so ``collision`` does not apply. A destination pixel whose
weights sum to less than :data:`MIN_SPLAT_WEIGHT` is a hole; stages 2-4 are
unchanged. On real video the rounding of stage 1 misplaces pixels by up to
half a pixel and a collision keeps one of several noisy flow vectors, which
costs more than the warp gains when a mouth moves a pixel or two between
frames: predicting frame ``t + 2`` of GRID talker s1 from frames ``t`` and
``t + 4`` (48 clips, mouth box, bergen flow, no median;
:mod:`miketalk_lab.evaluation.inbetween`), the rounded morph is 0.23 dB under a
cross-dissolve and the bilinear one 0.18 dB over it. Real frames also carry
detail the 3x3 median removes (the median of a real frame is 41.6 dB from the
frame), so on them ``median=False`` goes with ``splat="bilinear"``. The
default (``"nearest"``) is the paper's Eq. 3-6 and its output is unchanged.
"""

from __future__ import annotations

import functools
import numbers
from typing import Literal

import numpy as np

from miketalk.checks import check_flow, check_image
from miketalk.errors import MiketalkError
from miketalk.render.kernels import fill_holes as _fill_holes
from miketalk.render.kernels import splat as _splat

Collision = Literal["motion", "scan"]


Splat = Literal["nearest", "bilinear"]


#: The reserved colour holes hold before filling (paper §5.4: "a special reserved color").
HOLE_VALUE = 0


#: With ``splat="bilinear"``: a destination pixel whose splat weights sum to less is a hole.
MIN_SPLAT_WEIGHT = 0.01


def _check_alpha(alpha: object, name: str = "alpha") -> float:
    """Return ``alpha`` as a float after checking it is a real number in [0, 1]."""
    if isinstance(alpha, bool | np.bool_) or not isinstance(alpha, numbers.Real):
        raise MiketalkError(f"{name} must be a number in [0, 1], got {alpha!r}")
    value = float(alpha)
    if not 0.0 <= value <= 1.0:  # also rejects NaN
        raise MiketalkError(f"{name} must be in [0, 1], got {value}")
    return value


def _check_collision(collision: object) -> str:
    if collision not in ("motion", "scan"):
        raise MiketalkError(f'collision must be "motion" or "scan", got {collision!r}')
    return str(collision)


def _check_splat(splat: object) -> str:
    if splat not in ("nearest", "bilinear"):
        raise MiketalkError(f'splat must be "nearest" or "bilinear", got {splat!r}')
    return str(splat)


def _contiguous(array: np.ndarray, dtype: type) -> np.ndarray:
    """C-contiguous ``dtype`` array (the kernels' layout), copying only when needed."""
    return np.ascontiguousarray(array, dtype=dtype)


def _as_hwc(image: np.ndarray) -> np.ndarray:
    """(H, W) or (H, W, C) uint8 -> C-contiguous (H, W, C)."""
    if image.ndim == 2:
        image = image[:, :, None]
    return _contiguous(image, np.uint8)


def _priority(flow: np.ndarray, collision: str) -> np.ndarray:
    """Collision priority of each source pixel: squared motion length, or 0 for scan order.

    ``dx * dx + dy * dy`` in float32, by elementwise operations that round the
    same on every CPU (``np.einsum`` may fuse them into FMA instructions where
    the CPU has them, and is slower).
    """
    if collision == "scan":
        return np.zeros(flow.shape[:2], dtype=np.float32)
    dx, dy = flow[..., 0], flow[..., 1]
    priority = dx * dx
    priority += dy * dy
    return priority


@functools.lru_cache(maxsize=4)
def _grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Read-only float64 row and column coordinates of an (H, W) image, cached."""
    ys, xs = np.indices((h, w), dtype=np.float64)
    ys.flags.writeable = False
    xs.flags.writeable = False
    return ys, xs


def _bilinear_splat(
    planes: np.ndarray, flow: np.ndarray, scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear forward splat of an image along ``scale * flow`` (``splat="bilinear"``).

    Parameters
    ----------
    planes : ndarray, shape (C, H * W), float64
        The source image, one row per channel, pixels in scan order.
    flow : ndarray, shape (H, W, 2), float32
        Displacements of the source pixels.
    scale : float
        Scale of the flow.

    Returns
    -------
    warped : ndarray, shape (H * W, C), float64
        The weighted mean of the sources landing on each pixel; 0 at holes.
    hole : ndarray of bool, shape (H * W,)
        True where the weights sum to less than :data:`MIN_SPLAT_WEIGHT`.
    """
    h, w = flow.shape[:2]
    n = h * w
    ys, xs = _grid(h, w)
    tx = xs + scale * flow[..., 0]
    ty = ys + scale * flow[..., 1]
    x0, y0 = np.floor(tx), np.floor(ty)
    fx, fy = (tx - x0).ravel(), (ty - y0).ravel()
    gx, gy = 1.0 - fx, 1.0 - fy
    x0, y0 = x0.astype(np.intp).ravel(), y0.astype(np.intp).ravel()
    x = np.stack((x0, x0 + 1, x0, x0 + 1))
    y = np.stack((y0, y0, y0 + 1, y0 + 1))
    weight = np.stack((gx * gy, fx * gy, gx * fy, fx * fy))
    # corners outside the image go to a spare bin n, dropped afterwards
    dest = np.where((x >= 0) & (x < w) & (y >= 0) & (y < h), y * w + x, n).ravel()
    total = np.bincount(dest, weight.ravel(), minlength=n + 1)[:n]
    hole = total < MIN_SPLAT_WEIGHT
    warped = np.empty((planes.shape[0], n), np.float64)
    for c, plane in enumerate(planes):
        warped[c] = np.bincount(dest, (weight * plane).ravel(), minlength=n + 1)[:n]
    warped /= np.where(hole, 1.0, total)
    warped[:, hole] = HOLE_VALUE
    return warped.T, hole


def _planes(pixels: np.ndarray) -> np.ndarray:
    """(H * W, C) pixels as (C, H * W) float64 channel planes."""
    return np.ascontiguousarray(pixels.T, dtype=np.float64)


def _round_u8(values: np.ndarray) -> np.ndarray:
    """Round half up and clip to uint8, as the kernels round."""
    return np.clip(np.floor(values + 0.5), 0, 255).astype(np.uint8)


def _gather(pixels: np.ndarray, index: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Warped image from a splat's index buffer; holes get :data:`HOLE_VALUE`."""
    warped = pixels[np.maximum(index, 0).ravel()].reshape(shape)
    warped[index < 0] = HOLE_VALUE
    return warped


def forward_warp(
    image: np.ndarray,
    flow: np.ndarray,
    alpha: float,
    *,
    collision: Collision = "motion",
    splat: Splat = "nearest",
) -> tuple[np.ndarray, np.ndarray]:
    """Forward-warp ``image`` along ``alpha * flow`` (paper Eq. 3-4, Fig. 6).

    Pixel ``p`` is pushed to ``RND(p + alpha * flow(p))`` with
    ``RND(t) = floor(t + 0.5)``; pixels landing outside the image are dropped;
    collisions follow ``collision`` (module docstring).

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3), uint8
        The image to push.
    flow : ndarray, shape (H, W, 2)
        Displacements ``(dx, dy)`` of each pixel of ``image``.
    alpha : float
        Scale of the flow, in ``[0, 1]``.
    collision : {"motion", "scan"}, keyword-only
        Collision rule.
    splat : {"nearest", "bilinear"}, keyword-only
        ``"bilinear"`` spreads each pixel over the four pixels around its landing
        point and averages (module docstring); ``collision`` is then not used.

    Returns
    -------
    warped : ndarray
        uint8, the shape of ``image``; holes hold :data:`HOLE_VALUE` (0).
    hole : ndarray of bool, shape (H, W)
        True where no source pixel landed.

    Raises
    ------
    MiketalkError
        Naming the argument, for any malformed input.
    """
    image = check_image(image, "image", uint8_only=True)
    flow = _contiguous(check_flow(flow, "flow", image.shape[:2]), np.float32)
    alpha = _check_alpha(alpha)
    collision = _check_collision(collision)
    hwc = _as_hwc(image)
    h, w, nc = hwc.shape
    if _check_splat(splat) == "bilinear":
        warped, hole = _bilinear_splat(_planes(hwc.reshape(h * w, nc)), flow, alpha)
        return _round_u8(warped).reshape(image.shape), hole.reshape(h, w)
    index = np.empty((h, w), np.int32)
    depth = np.empty((h, w), np.float32)
    _splat(flow, _priority(flow, collision), alpha, index, depth)
    warped = _gather(hwc.reshape(h * w, nc), index, hwc.shape)
    return warped.reshape(image.shape), index < 0


def fill_holes_scanline(image: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """Fill holes along scanlines by linear interpolation (paper §5.4, after [9]).

    Each row is scanned left to right; a run of hole pixels between two
    non-hole pixels gets the values on the straight line between them
    (per channel, rounded half up). A run touching the left or right edge of
    the row takes the value of its one non-hole end (the nearest non-hole pixel
    is extended). A row with no non-hole pixel at all is filled afterwards in
    the column direction the same way, between the nearest complete rows above
    and below (extended at the top and bottom of the image). So no hole is left,
    unless the image has no non-hole pixel at all: then it is returned unchanged.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3), uint8
        The image with holes (their values are ignored).
    hole : ndarray of bool, shape (H, W)
        True at the pixels to fill.

    Returns
    -------
    ndarray
        A filled copy of ``image``.

    Raises
    ------
    MiketalkError
        If ``image`` is not a uint8 image or ``hole`` is not a bool mask of its size.

    Examples
    --------
    >>> import numpy as np
    >>> row = np.array([[0, 10, 0, 0, 40, 0]], np.uint8)
    >>> fill_holes_scanline(row, row == 0)
    array([[10, 10, 20, 30, 40, 40]], dtype=uint8)
    """
    image = check_image(image, "image", uint8_only=True)
    if not isinstance(hole, np.ndarray) or hole.dtype != np.bool_:
        raise MiketalkError("hole must be a numpy bool array")
    if hole.shape != image.shape[:2]:
        raise MiketalkError(f"hole has shape {hole.shape} but image is {image.shape[:2]}")
    out = _as_hwc(image).copy()
    if not _fill_holes(out, _contiguous(hole, np.bool_)):
        return image.copy()
    return out.reshape(image.shape)
