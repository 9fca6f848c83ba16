"""Labelled image grids: viseme contact sheets, frame strips, morph strips."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np


def grid(
    images: Sequence[np.ndarray],
    labels: Sequence[str],
    *,
    cols: int,
    scale: float = 1.0,
    pad: int = 4,
) -> np.ndarray:
    """Images in a grid, each with its label underneath; RGB uint8 out."""
    if not images:
        raise ValueError("no images for the grid")
    tiles = []
    for image, label in zip(images, labels, strict=True):
        tile = image if image.ndim == 3 else np.repeat(image[..., None], 3, axis=2)
        if scale != 1.0:
            tile = cv2.resize(tile, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        h, w = tile.shape[:2]
        band = np.full((22, w, 3), 255, np.uint8)
        cv2.putText(band, label, (3, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
        tiles.append(np.vstack([tile, band]))
    h, w = tiles[0].shape[:2]
    rows = -(-len(tiles) // cols)
    sheet = np.full((rows * (h + pad) + pad, cols * (w + pad) + pad, 3), 255, np.uint8)
    for i, tile in enumerate(tiles):
        r, c = divmod(i, cols)
        y, x = pad + r * (h + pad), pad + c * (w + pad)
        sheet[y : y + h, x : x + w] = tile
    return sheet
