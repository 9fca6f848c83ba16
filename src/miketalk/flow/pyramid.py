"""The coarse-to-fine loop (the paper's section 5.2 and its ref. [8]), shared by pyramid solvers.

A solver refines a flow at one level: ``solver(a, b, flow) -> flow``, all float32
at that level's size. :func:`coarse_to_fine` builds the Gaussian pyramids,
runs the solver from the coarsest level up, and carries the flow to the next
finer level by ``cv2.pyrUp`` and doubling of the vectors.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from miketalk.errors import MiketalkError

Solver = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def gaussian_pyramid(image: np.ndarray, levels: int) -> list[np.ndarray]:
    """Gaussian pyramid, finest first: ``levels`` images, each ``cv2.pyrDown`` of the one before.

    ``cv2.pyrDown`` blurs with the 5-tap binomial kernel of Burt & Adelson (the
    paper's ref. [8]) and halves the size, odd sizes rounding up; coarse pixel
    ``i`` sits on fine pixel ``2 i``. If ``levels`` asks for more levels than
    halvings down to 1x1, the pyramid stops at 1x1.
    """
    pyramid = [image]
    for _ in range(levels - 1):
        if pyramid[-1].shape[:2] == (1, 1):
            break
        pyramid.append(cv2.pyrDown(pyramid[-1]))
    return pyramid


def resize_flow(flow: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Resize a flow field to ``shape = (H, W)``, scaling dx and dy by the size ratio.

    From one pyramid level to the next finer one this is ``cv2.pyrUp``, the
    inverse of the ``cv2.pyrDown`` that built the level: coarse pixel ``i`` sits
    on fine pixel ``2 i`` in both, so the upsampled flow stays aligned with
    the images. Other size changes use bilinear ``cv2.resize``.
    """
    h, w = shape
    fh, fw = flow.shape[:2]
    if (fh, fw) == (h, w):
        return flow
    if (fh, fw) == ((h + 1) // 2, (w + 1) // 2):
        out = cv2.pyrUp(flow, dstsize=(w, h))
    else:
        out = cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR)
    out[..., 0] *= np.float32(w / fw)
    out[..., 1] *= np.float32(h / fh)
    return out


def coarse_to_fine(
    image_a: np.ndarray,
    image_b: np.ndarray,
    solver: Solver,
    *,
    levels: int,
    flow0: np.ndarray | None = None,
) -> np.ndarray:
    """Run ``solver`` from the coarsest pyramid level to the finest.

    Parameters
    ----------
    image_a, image_b : ndarray, shape (H, W), float32
        Grey images; the flow is from ``image_a`` to ``image_b``.
    solver : callable
        ``solver(a, b, flow) -> flow`` refining ``flow`` at one level.
    levels : int
        Number of pyramid levels, the full-resolution one included (1 = no
        pyramid). A displacement of ``d`` pixels is ``d / 2**(levels-1)`` at
        the coarsest level, where a gradient-based solver handles about one
        pixel.
    flow0 : ndarray, shape (H, W, 2), optional
        Initial flow at full resolution, resized to the coarsest level (so only
        its coarse content survives); zero by default.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    if not isinstance(levels, int | np.integer) or levels < 1:
        raise MiketalkError(f"levels must be an integer >= 1, got {levels!r}")
    pyr_a = gaussian_pyramid(image_a, levels)
    pyr_b = gaussian_pyramid(image_b, levels)
    coarsest = pyr_a[-1].shape[:2]
    if flow0 is None:
        flow = np.zeros((*coarsest, 2), np.float32)
    else:
        flow = resize_flow(np.asarray(flow0, np.float32), coarsest)
    for a, b in zip(reversed(pyr_a), reversed(pyr_b), strict=True):
        flow = solver(a, b, resize_flow(flow, a.shape[:2]))
    return flow
