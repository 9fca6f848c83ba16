"""The frame's jaw made to meet the synthesized one where a render is blended into it.

Where the real jaw opens more or less than the synthesized one, its line would show
twice at the blend's edge: the frame's jaw outside the mask, the render's inside (a
dark notch on the jaw line, a doubled chin). Two remedies, both used by
:class:`miketalk.composite.compositor.Compositor`:

* :func:`follow_render` warps the frame's lower face about the mask to follow the
  render, by the dense flow from one to the other, so the jaw line outside the mask
  continues the render's inside it;
* :func:`skin_weight` keeps the mask off the reference's backdrop and clothes, so the
  render's collar beside its jaw is never pasted over the frame's own.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["follow_render", "skin_weight"]

Box = tuple[int, int, int, int]


def skin_weight(
    reference: np.ndarray, face: np.ndarray, *, drop: float = 0.06, sigma: float = 2.0
) -> np.ndarray:
    """Where the reference shows skin or lips, not the backdrop or clothes: (H, W) float32.

    A pixel is kept when its red chromaticity ``r / (r + g + b)`` is at least the face's
    median less ``drop`` (on s1's reference the backdrop and the denim collar fall below,
    the face, the neck and the lips above); the kept region is closed (small holes filled)
    and its edge blurred by ``sigma`` pixels. Multiplied into the blend mask, the render's
    collar or backdrop beside the jaw is never pasted over the frame's own.

    Parameters
    ----------
    reference : numpy.ndarray
        (H, W, 3) uint8 RGB.
    face : numpy.ndarray
        (H, W) bool, the face (its median colour is the skin's).
    """
    rgb = np.asarray(reference, np.float32)
    red = rgb[..., 0] / np.maximum(rgb.sum(axis=2), 1.0)
    if not face.any():
        return np.ones(red.shape, np.float32)
    keep = (red >= float(np.median(red[face])) - drop).astype(np.uint8)
    keep = cv2.morphologyEx(
        keep, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    )
    return cv2.GaussianBlur(keep.astype(np.float32), (0, 0), sigma)


def follow_render(
    here: np.ndarray,
    mouth: np.ndarray,
    alpha: np.ndarray,
    ref_y: np.ndarray,
    mouth_box: Box,
    *,
    within: np.ndarray | None = None,
) -> np.ndarray:
    """The frame's pixels about the mask moved to follow the render's (the jaw line).

    Parameters
    ----------
    here, mouth : numpy.ndarray
        (h, w, 3) float32: the frame's pixels in the placement's box, and the render
        carried there.
    alpha : numpy.ndarray
        (h, w) float32: the blend mask there.
    ref_y : numpy.ndarray
        (h, w) float32: the reference row each pixel shows (:attr:`Placement.map_y`).
    mouth_box : tuple of int
        ``(x, y, w, h)`` of the mouth in the reference.
    within : numpy.ndarray, optional
        (h, w) float32 in [0, 1] multiplied into the warp's weight: where it may move the
        frame's pixels (a face crop's face, :class:`~miketalk.composite.compositor.
        Compositor` ``follow_within``), so the room beside the jaw is never bent.

    Returns
    -------
    numpy.ndarray
        (h, w, 3) float32: ``here`` sampled at ``q + s(q) b(q)``, where ``b`` is the DIS
        flow from the render to the frame (``mouth(q) ~ here(q + b(q))``), smoothed over
        a fifth of a mouth width, and ``s`` is one on the mask and fades out over half a
        mouth width outside it, and from the mouth's centre up to its top.
    """
    from miketalk.flow.opencv import dis_flow
    from miketalk.flow.warp import backward_warp

    w = float(mouth_box[2])
    mouth_u8, here_u8 = (np.clip(im + 0.5, 0, 255).astype(np.uint8) for im in (mouth, here))
    flow = _blur_half(dis_flow(mouth_u8, here_u8, preset="fast"), 0.2 * w)
    near = _blur_half((alpha > 0.5).astype(np.float32), 0.25 * w)
    weight = np.minimum(1.0, 2.0 * near)
    cy = mouth_box[1] + mouth_box[3] / 2
    weight *= np.clip((ref_y - (cy - 0.3 * w)) / (0.3 * w), 0.0, 1.0)
    if within is not None:
        weight *= within
    return backward_warp(here, weight[..., None] * flow)


def _blur_half(image: np.ndarray, sigma: float) -> np.ndarray:
    """A wide Gaussian blur done at half the resolution (smooth result, a quarter the pixels)."""
    h, w = image.shape[:2]
    if min(h, w) < 8:
        return cv2.GaussianBlur(image, (0, 0), sigma)
    small = cv2.resize(image, ((w + 1) // 2, (h + 1) // 2), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / 2)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)
