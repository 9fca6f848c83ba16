"""One frame's affine registration: ECC with the mask on the reference, on a pyramid level."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


def _hom(w: np.ndarray) -> np.ndarray:
    out = np.eye(3)
    out[:2] = w
    return out


def _to_level(scale: float, x0: int, y0: int) -> np.ndarray:
    """3x3 map from full-size frame coordinates to a crop at ``(x0, y0)`` resized by ``scale``."""
    c = (scale - 1) / 2  # pixel centres: INTER_AREA at 1/2 averages pixels 2i and 2i+1
    return np.array([[scale, 0, c - scale * x0], [0, scale, c - scale * y0], [0, 0, 1.0]])


def _aligned_box(
    x0: int, y0: int, x1: int, y1: int, q: int, w: int, h: int
) -> tuple[int, int, int, int]:
    """The box clipped to the frame, its size cut to a multiple of ``q``."""
    x0, y0, x1, y1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
    return x0, y0, x0 + (x1 - x0) // q * q, y0 + (y1 - y0) // q * q


@dataclass(frozen=True)
class _Level:
    scale: float
    template: np.ndarray  # float32 crop of the reference's luma at this scale
    mask: np.ndarray  # uint8 0/255, same size
    ref_to_tmpl: np.ndarray  # 3x3: full-size reference coordinates -> template crop
    tmpl_to_ref: np.ndarray
    frame_to_input: np.ndarray  # 3x3: full-size frame coordinates -> input crop
    input_to_frame: np.ndarray
    input_size: tuple[int, int]  # (w, h) of the input crop at this scale
    criteria: tuple[int, int, float]


def _ecc(
    level: _Level, mask: np.ndarray, image: np.ndarray, warp: np.ndarray, blur: int
) -> tuple[float, np.ndarray]:
    """One ECC run at ``level``: the template's pixels under ``mask`` against ``image``.

    The mask belongs to the template (``cv2.findTransformECCWithMask``, OpenCV
    4.13 and later): older OpenCV only takes a mask on the input image, so it
    gets the template's carried over by the start warp, which is biased (on a
    synthetic face moved by a known transform, 0.3 to 0.5 px off where the
    template mask is 0.03 px off).
    """
    if _WITH_MASK:
        ones = np.full(image.shape, 255, np.uint8)
        rho, warp = cv2.findTransformECCWithMask(
            level.template, image, mask, ones, warp, cv2.MOTION_AFFINE, level.criteria, blur
        )
    else:  # pragma: no cover - OpenCV < 4.13
        in_mask = cv2.warpAffine(mask, warp, level.input_size, flags=cv2.INTER_NEAREST)
        rho, warp = cv2.findTransformECC(
            level.template, image, warp, cv2.MOTION_AFFINE, level.criteria, in_mask, blur
        )
    return float(rho), warp


_WITH_MASK = hasattr(cv2, "findTransformECCWithMask")
