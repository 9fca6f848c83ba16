"""The mouth box of a clip found from where the lips' redness changes over the clip."""

from __future__ import annotations

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.mouth.region import Box


def find_mouth_box(
    frames: np.ndarray,
    *,
    head: np.ndarray | None = None,
    size: tuple[float, float] = (0.45, 0.30),
    step: int = 2,
) -> Box:
    """The mouth box of a frontal talking head, from where the lips' redness changes.

    Lips are redder than skin and the mouth's inside is not, so while a person
    speaks the CIELAB ``a*`` (green-red) channel changes most at the lips. Per
    pixel, the 75th percentile over the clip of ``|a* - median a*|`` is taken
    (blinks, a few frames, do not reach it) and smoothed; its peak is searched
    in the middle 40 % of the head's width, between 0.85 and 1.4 head widths
    below the top of the head (the mouth of an upright frontal head is about
    1.1 head widths below its top, the eyes about 0.6). The box is centred
    across on the weighted centre of the change around the peak, and up and
    down on the lips (the redness of the median frame there), so that it holds
    both lips even when the lower lip's edge moves most.

    Parameters
    ----------
    frames : ndarray, shape (N, H, W, 3), uint8 RGB
        The clip (at least 3 frames).
    head : ndarray of bool, shape (H, W), optional, keyword-only
        The head (hair and ears included) against the background; by default
        :func:`miketalk.stabilize.locate_head` of the clip's median frame.
    size : (float, float), keyword-only
        The box's width and height as fractions of the head's width (for
        GRID's 360x288 frames the head is about 150 px wide: a 68x45 box).
    step : int, keyword-only
        Use every ``step``-th frame.

    Returns
    -------
    (x, y, w, h) : tuple of int
        Inside the frame.

    Raises
    ------
    MiketalkError
        For frames that are not an RGB clip, when no head is found, or when the
        head is too close to the frame's bottom edge.
    """
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        raise MiketalkError(f"frames must be (N, H, W, 3) uint8, got {frames.shape} {frames.dtype}")
    if frames.shape[0] < 3:
        raise MiketalkError(f"find_mouth_box needs at least 3 frames, got {frames.shape[0]}")
    sample = frames[:: max(1, int(step))]
    height, width = frames.shape[1:3]
    if head is None:
        from miketalk.stabilize import locate_head

        head = locate_head(np.median(sample, axis=0).astype(np.uint8))
    head = np.asarray(head, bool)
    if head.shape != (height, width) or not head.any():
        raise MiketalkError(f"the head mask must be a non-empty ({height}, {width}) bool array")
    cols = np.flatnonzero(head.any(axis=0))
    top = int(np.flatnonzero(head.any(axis=1))[0])
    left, span = int(cols[0]), int(cols[-1]) - int(cols[0]) + 1
    redness = np.stack(
        [cv2.cvtColor(cv2.GaussianBlur(f, (0, 0), 1.5), cv2.COLOR_RGB2LAB)[..., 1] for f in sample]
    ).astype(np.float32)
    typical = np.median(redness, axis=0)
    change = np.percentile(np.abs(redness - typical), 75, axis=0).astype(np.float32)
    score = cv2.GaussianBlur(change, (0, 0), max(1.0, 0.03 * span))
    region = np.zeros((height, width), bool)
    region[
        top + int(0.85 * span) : top + int(1.4 * span) + 1,
        left + int(0.3 * span) : left + int(0.7 * span) + 1,
    ] = True
    if not region.any():
        raise MiketalkError("the head is too close to the frame's bottom to find its mouth")
    masked = np.where(region, score, -np.inf)
    py, px = np.unravel_index(int(np.argmax(masked)), masked.shape)
    ry, rx = max(1, int(0.12 * span)), max(1, int(0.2 * span))
    ys, xs = slice(max(0, py - ry), py + ry + 1), slice(max(0, px - rx), px + rx + 1)
    yy, xx = np.mgrid[ys, xs]
    moving = np.maximum(score[ys, xs] - 0.5 * score[py, px], 0.0)
    cx = (moving * xx).sum() / moving.sum()
    lips = typical[ys, xs] - np.median(typical[head])
    lips = np.maximum(lips - 0.5 * lips.max(), 0.0)
    cy = (lips * yy).sum() / lips.sum() if lips.sum() > 0 else float(py)
    bw = min(width, max(8, round(size[0] * span)))
    bh = min(height, max(8, round(size[1] * span)))
    x0 = min(max(0, round(cx - bw / 2)), width - bw)
    y0 = min(max(0, round(cy - bh / 2)), height - bh)
    return int(x0), int(y0), int(bw), int(bh)
