"""How still a stabilized clip is: residual optical-flow motion over a mask."""

from __future__ import annotations

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.stabilize.locate import _u8gray


def residual_motion(frames: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per frame, the mean optical-flow magnitude (pixels) over ``mask`` from ``reference``.

    The flow is OpenCV's DIS (Kroeger et al. 2016) at its ``MEDIUM`` preset,
    on luma, from the reference to the frame, over the whole frame (so the
    flow at the mask's edge sees its surroundings); the magnitude is averaged
    over the mask's pixels.

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8 RGB or (N, H, W) uint8.
    reference : numpy.ndarray
        (H, W, 3) or (H, W) uint8.
    mask : numpy.ndarray
        (H, W) bool.

    Returns
    -------
    numpy.ndarray
        (N,) float64 pixels.
    """
    dis = cv2.DISOpticalFlow_create(cv2.DISOpticalFlow_PRESET_MEDIUM)
    ref = _u8gray(reference)
    m = np.asarray(mask, bool)
    if not m.any():
        raise MiketalkError("residual_motion: the mask is empty")
    out = np.empty(len(frames))
    for i, frame in enumerate(frames):
        flow = dis.calc(ref, _u8gray(frame), None)[m]
        out[i] = float(np.sqrt((flow * flow).sum(axis=1)).mean())
    return out
