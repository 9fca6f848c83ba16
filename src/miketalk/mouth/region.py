"""Where the mouth is in a clip corpus's frames, and its pixels.

The corpus stage records the mouth box (where the lips move most,
``regions.json``); boxes about its centre, in mouth widths, are what the
measures, the viseme choice and the flows look at.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

Box = tuple[int, int, int, int]

#: The file in a clip corpus where the corpus stage records its regions (mouth box, size).
REGIONS = "regions.json"

#: :func:`mouth_region`'s box about the mouth box's centre, in mouth widths: side, above, below.
REGION_EXTENT = (0.65, 0.45, 0.55)

#: :func:`flow_region`'s box about the mouth box's centre, in mouth widths: side, above, below.
FLOW_EXTENT = (1.5, 0.6, 1.3)

__all__ = [
    "FLOW_EXTENT",
    "REGIONS",
    "REGION_EXTENT",
    "Box",
    "flow_region",
    "grey_mouths",
    "mouth_box",
    "mouth_opening",
    "mouth_region",
]


def mouth_box(corpus_dir: str | Path) -> tuple[int, int, int, int]:
    """The mouth box ``(x, y, w, h)`` the corpus stage found (where the lips move most)."""
    regions = json.loads((Path(corpus_dir) / REGIONS).read_text())
    return tuple(int(v) for v in regions["mouth_box"])


def mouth_region(corpus_dir: str | Path) -> tuple[int, int, int, int]:
    """The mouth region measures and viseme choices look at: lips, teeth and the opening.

    The mouth box marks where the lips move most (often a thin band at the
    lips' meeting line); the region is centred on it, 1.3 mouth widths wide
    and one high, so that it holds both lips and the open mouth between them.
    """
    return _about_mouth(corpus_dir, REGION_EXTENT)


def flow_region(corpus_dir: str | Path) -> tuple[int, int, int, int]:
    """The box flows are estimated in: the mouth and what moves with it, jaw and cheeks.

    In mouth widths ``w`` about the mouth box's centre: one each side, 0.6
    above (to the nose, below the eyes, which blink) and 1.3 below (the chin,
    which follows the jaw), clipped to the frame.
    """
    return _about_mouth(corpus_dir, FLOW_EXTENT)


def _about_mouth(
    corpus_dir: str | Path, extent: tuple[float, float, float]
) -> tuple[int, int, int, int]:
    """A box about the mouth box's centre, in mouth widths each way (``extent``: side, above,
    below), clipped to the frame."""
    side, above, below = extent
    regions = json.loads((Path(corpus_dir) / REGIONS).read_text())
    x, y, w, h = regions["mouth_box"]
    height, width = regions["size"]
    cx, cy = x + w / 2, y + h / 2
    x0, x1 = max(0, round(cx - side * w)), min(width, round(cx + side * w))
    y0, y1 = max(0, round(cy - above * w)), min(height, round(cy + below * w))
    return x0, y0, x1 - x0, y1 - y0


def grey_mouths(frames: np.ndarray, box: Box) -> np.ndarray:
    """The grey mouth box of every frame: ``(N, h, w)`` float32 (BT.601 luma)."""
    x, y, w, h = box
    crop = np.asarray(frames)[:, y : y + h, x : x + w].astype(np.float32)
    if crop.ndim == 3:
        return crop
    return crop @ np.array([0.299, 0.587, 0.114], np.float32)


def mouth_opening(frames: np.ndarray, region: np.ndarray) -> np.ndarray:
    """Per-frame mouth opening signal: the mean darkness of ``region``.

    An open mouth shows its dark interior, so the region's mean darkness
    ``1 - grey / 255`` rises as the mouth opens. Unlike a count of pixels under
    a threshold, it is linear in a blend of two images, so a morph and a render
    with the same timing give signals with the same timing.

    Parameters
    ----------
    frames : (N, H, W, 3) or (N, H, W) uint8
    region : (H, W) bool
        The mouth region.
    """
    pixels = frames[:, region].astype(np.float64)  # (N, M) or (N, M, 3): the region only
    return 1.0 - pixels.reshape(len(frames), -1).mean(axis=1) / 255.0
