"""Frames warped onto the reference by their affine transforms and a clip's conform field."""

from __future__ import annotations

import cv2
import numpy as np


def warp_to_reference(
    frames: np.ndarray,
    transforms: np.ndarray,
    *,
    field: np.ndarray | None = None,
    interpolation: int = cv2.INTER_LINEAR,
) -> np.ndarray:
    """Warp frames onto the reference.

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) or (N, H, W).
    transforms : numpy.ndarray
        (N, 2, 3) affine maps from reference pixel coordinates to each frame's.
    field : numpy.ndarray, optional
        (H, W, 2) conform field, applied before the transforms.
    interpolation : int
        OpenCV interpolation flag.

    Returns
    -------
    numpy.ndarray
        Frames like ``frames``: output pixel ``p`` is the frame at ``T @ (p + F(p))``
        (the edges replicated).
    """
    frames = np.asarray(frames)
    out = np.empty_like(frames)
    h, w = frames.shape[1:3]
    if field is None:
        flags = interpolation | cv2.WARP_INVERSE_MAP
        for i in range(frames.shape[0]):
            out[i] = cv2.warpAffine(
                frames[i], transforms[i], (w, h), flags=flags, borderMode=cv2.BORDER_REPLICATE
            )
        return out
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    px, py = xx + field[..., 0], yy + field[..., 1]
    for i in range(frames.shape[0]):
        t = transforms[i].astype(np.float32)
        map_x = t[0, 0] * px + t[0, 1] * py + t[0, 2]
        map_y = t[1, 0] * px + t[1, 1] * py + t[1, 2]
        out[i] = cv2.remap(frames[i], map_x, map_y, interpolation, borderMode=cv2.BORDER_REPLICATE)
    return out
