"""The paper's flow estimator: coarse-to-fine, gradient-based, after Bergen & Hingorani.

Section 5.2 of the paper uses "the coarse-to-fine, gradient-based optical flow
algorithms developed by [4]" (Bergen & Hingorani 1990) inside a pyramid [8]
(Burt & Adelson's Laplacian pyramid). This module is our reading of that
recipe: a Gaussian pyramid whose levels are band-passed (a difference of
Gaussians, which is what a Laplacian level is), and at each level a few
warp-and-refine iterations of a local least-squares (Lucas-Kanade) solve.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from miketalk.checks import check_pair, to_grey_float32
from miketalk.errors import MiketalkError
from miketalk.flow.pyramid import coarse_to_fine

_REMAP_FLAGS = cv2.INTER_LINEAR | cv2.WARP_RELATIVE_MAP


def bergen_flow(
    image_a: np.ndarray,
    image_b: np.ndarray,
    *,
    levels: int = 6,
    iterations: int = 3,
    window: float = 3.0,
    highpass: float = 3.0,
    regularization: float = 1e-5,
    median: int = 5,
    max_step: float = 1.0,
) -> np.ndarray:
    """Flow from ``image_a`` to ``image_b`` by coarse-to-fine Lucas-Kanade (paper section 5.2).

    The result is the correspondence map C_0 of the paper's Eq. 1:
    ``image_a(p) ~ image_b(p + flow(p))``.

    At every pyramid level, coarsest first, and for ``iterations`` rounds:

    1. warp B backwards along the current flow (Fig. 9): ``B_w(p) = B(p + flow(p))``;
    2. take the temporal difference ``I_t = B_w - A`` and the spatial gradient
       ``(I_x, I_y)`` of ``(A + B_w) / 2``;
    3. for each pixel, the increment ``d`` is the solution of the 2x2 system
       ``(G + eps I) d = -[sum w I_x I_t, sum w I_y I_t]`` with the structure
       tensor ``G = sum w [[I_x^2, I_x I_y], [I_x I_y, I_y^2]]`` summed over a
       Gaussian window ``w``. The damping ``eps`` shrinks the increment of
       badly conditioned pixels (flat regions, edges along one direction)
       towards zero, so they keep the flow carried up from coarser levels;
    4. clip ``|d|`` to ``max_step`` (the linearisation holds for about a
       pixel), median-filter it, and add it to the flow.

    Pixels whose current match ``p + flow(p)`` lies outside B carry no
    brightness constraint (``I_t = 0`` there). The flow then goes up one level
    by ``cv2.pyrUp`` and doubling.

    Parameters
    ----------
    image_a, image_b : ndarray, shape (H, W) or (H, W, 3)
        Grey or RGB images of the same shape and dtype: uint8 (0-255) or float
        (0-1). RGB is converted to grey (BT.601 luma); work is in float32.
    levels : int
        Pyramid levels, full resolution included (1 = no pyramid). Each level
        halves the displacement: with 6 levels a 60-pixel motion is under 2
        pixels at the coarsest level.
    iterations : int
        Warp-and-refine rounds per level.
    window : float
        Standard deviation, in pixels of the current level, of the Gaussian
        window over which the least-squares sums are taken.
    highpass : float
        Standard deviation of the local mean subtracted from each level
        (difference of Gaussians, a Laplacian-pyramid level [8]); it removes
        brightness offsets between the images. 0 keeps the Gaussian levels.
    regularization : float
        Damping ``eps`` added to the diagonal of the structure tensor, in
        squared intensity-per-pixel units (intensities in 0-1).
    median : {0, 3, 5}
        Size of the median filter applied to each increment (0: none).
    max_step : float
        Largest increment, in pixels of the current level, per iteration.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
        ``[..., 0]`` is dx, ``[..., 1]`` is dy.

    Raises
    ------
    MiketalkError
        If the images differ in shape or dtype, hold NaN/inf, or a setting is
        out of range.

    References
    ----------
    .. [4] J. R. Bergen and R. Hingorani. Hierarchical motion-based frame rate
       conversion. David Sarnoff Research Center, 1990.
    .. [8] P. J. Burt and E. H. Adelson. The Laplacian pyramid as a compact
       image code. IEEE Trans. Communications 31(4), 1983.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> b = rng.random((64, 64)).astype(np.float32)
    >>> a = np.roll(b, -2, axis=1)           # a(x) = b(x + 2)
    >>> flow = bergen_flow(a, b, levels=3)
    >>> bool(abs(np.median(flow[..., 0]) - 2.0) < 0.05)
    True
    """
    a, b = check_pair(image_a, image_b)
    check_settings(
        levels=levels,
        iterations=iterations,
        window=window,
        highpass=highpass,
        regularization=regularization,
        median=median,
        max_step=max_step,
    )
    solver = functools.partial(
        _refine,
        iterations=iterations,
        window=float(window),
        highpass=float(highpass),
        regularization=np.float32(regularization),
        median=median,
        max_step=float(max_step),
    )
    return coarse_to_fine(to_grey_float32(a), to_grey_float32(b), solver, levels=int(levels))


def check_settings(**settings: float) -> None:
    """Raise MiketalkError naming the first out-of-range setting of :func:`bergen_flow`."""
    for name in ("levels", "iterations"):
        value = settings[name]
        if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < 1:
            raise MiketalkError(f"{name} must be an integer >= 1, got {value!r}")
    for name in ("window",):
        if not settings[name] > 0:
            raise MiketalkError(f"{name} must be > 0, got {settings[name]!r}")
    for name in ("highpass", "regularization", "max_step"):
        if not settings[name] >= 0:
            raise MiketalkError(f"{name} must be >= 0, got {settings[name]!r}")
    if settings["median"] not in (0, 3, 5):
        raise MiketalkError(f"median must be 0, 3 or 5, got {settings['median']!r}")


def _blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur truncated at 3 sigma, mirrored borders."""
    size = 2 * math.ceil(3.0 * sigma) + 1
    return cv2.GaussianBlur(image, (size, size), sigma, borderType=cv2.BORDER_REFLECT_101)


def _refine(
    a: np.ndarray,
    b: np.ndarray,
    flow: np.ndarray,
    *,
    iterations: int,
    window: float,
    highpass: float,
    regularization: np.float32,
    median: int,
    max_step: float,
) -> np.ndarray:
    """One pyramid level: ``iterations`` rounds of warp, linearise, solve, update."""
    h, w = a.shape
    if highpass > 0:
        a = a - _blur(a, highpass)
        b = b - _blur(b, highpass)
    u = np.ascontiguousarray(flow[..., 0])
    v = np.ascontiguousarray(flow[..., 1])
    # p + flow(p) stays inside B while -x <= u <= (w-1) - x and likewise for v.
    x = np.arange(w, dtype=np.float32)
    y = np.arange(h, dtype=np.float32)[:, None]
    u_lo, u_hi, v_lo, v_hi = -x, (w - 1) - x, -y, (h - 1) - y
    for _ in range(iterations):
        b_w = cv2.remap(b, u, v, _REMAP_FLAGS, borderMode=cv2.BORDER_REPLICATE)
        i_t = b_w - a
        inside = (u >= u_lo) & (u <= u_hi) & (v >= v_lo) & (v <= v_hi)
        i_t *= inside
        mean = (a + b_w) * np.float32(0.5)
        i_x = cv2.Sobel(mean, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
        i_y = cv2.Sobel(mean, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
        gxx = _blur(i_x * i_x, window) + regularization
        gyy = _blur(i_y * i_y, window) + regularization
        gxy = _blur(i_x * i_y, window)
        bx = _blur(i_x * i_t, window)
        by = _blur(i_y * i_t, window)
        inv_det = np.float32(1.0) / (gxx * gyy - gxy * gxy)
        du = (gxy * by - gyy * bx) * inv_det
        dv = (gxy * bx - gxx * by) * inv_det
        if max_step > 0:
            norm2 = du * du + dv * dv
            too_long = norm2 > max_step * max_step
            if too_long.any():
                shrink = np.where(too_long, max_step / np.sqrt(norm2 + 1e-30), 1.0)
                du *= shrink
                dv *= shrink
        if median > 1:
            du = cv2.medianBlur(du, median)
            dv = cv2.medianBlur(dv, median)
        u += du
        v += dv
    return cv2.merge((u, v))
