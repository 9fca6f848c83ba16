"""Checks of the true flow against the rendered images (used by the tests and the benchmark).

If ``flow`` is the true flow from A to B, backward-warping B along it reproduces A wherever
``valid`` holds, up to rendering noise (shading that changes with the surface normals,
texture filtering, bilinear resampling). A flow misaligned with the renderer by a sub-pixel
offset would leave a larger residual, so the offset that minimises the residual measures the
alignment of the flow with the renderer.
"""

from __future__ import annotations

import cv2
import numpy as np


def warp_back(image_b: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Sample B at ``p + flow(p)`` for every pixel p (bilinear): B brought back onto A."""
    h, w = flow.shape[:2]
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float32)
    return cv2.remap(
        image_b,
        cols + flow[..., 0].astype(np.float32),
        rows + flow[..., 1].astype(np.float32),
        interpolation=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )


def grey(image: np.ndarray) -> np.ndarray:
    """Luma of an RGB uint8 image as float64 grey levels (0-255)."""
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float64)


def _region(valid: np.ndarray, region: np.ndarray | None, erode: int) -> np.ndarray:
    m = valid.astype(np.uint8)
    if erode > 0:
        m = cv2.erode(m, np.ones((2 * erode + 1, 2 * erode + 1), np.uint8))
    m = m.astype(bool)
    return m if region is None else m & region


def warp_residual(
    image_a: np.ndarray,
    image_b: np.ndarray,
    flow: np.ndarray,
    valid: np.ndarray,
    *,
    region: np.ndarray | None = None,
    erode: int = 1,
    offset: tuple[float, float] = (0.0, 0.0),
) -> tuple[float, float]:
    """Mean absolute grey-level error of A against B warped back along ``flow``.

    Parameters
    ----------
    image_a, image_b : ndarray, shape (H, W, 3) uint8
        The two renders.
    flow, valid : ndarray
        The true flow from A to B and its mask.
    region : ndarray of bool, optional
        Restrict to this region as well (for example the mouth mask).
    erode : int
        Erode ``valid`` by this many pixels first (drops occlusion edges).
    offset : tuple of float
        A constant (dx, dy) added to the flow (to probe the alignment).

    Returns
    -------
    residual : float
        Mean |A - warp_back(B)| over the region (grey levels).
    baseline : float
        Mean |A - B| over the same region (no warp), for scale.
    """
    m = _region(valid, region, erode)
    if not m.any():
        return float("nan"), float("nan")
    shifted = flow + np.asarray(offset, dtype=np.float32)
    ga = grey(image_a)
    res = np.abs(grey(warp_back(image_b, shifted)) - ga)[m].mean()
    base = np.abs(grey(image_b) - ga)[m].mean()
    return float(res), float(base)


def alignment_offset(
    image_a: np.ndarray,
    image_b: np.ndarray,
    flow: np.ndarray,
    valid: np.ndarray,
    *,
    step: float = 0.2,
) -> tuple[float, float]:
    """The constant flow offset (dx, dy) that minimises the warp-back residual.

    A parabola through the residuals at offsets ``-step, 0, +step`` along each axis; its
    vertex estimates how far the flow is from the rendered motion, in pixels.
    """
    out = []
    for axis in (0, 1):
        r = []
        for s in (-step, 0.0, step):
            off = (s, 0.0) if axis == 0 else (0.0, s)
            r.append(warp_residual(image_a, image_b, flow, valid, offset=off)[0])
        curv = r[0] - 2 * r[1] + r[2]
        out.append(0.5 * step * (r[0] - r[2]) / curv if curv > 0 else float("nan"))
    return out[0], out[1]
