"""Image files: read as RGB, write PNG atomically."""

from __future__ import annotations

import os

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_path


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an image file as (H, W, 3) uint8 RGB, or raise MiketalkError naming it."""
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise MiketalkError(f"cannot read image {path}")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def write_png(path: str | os.PathLike[str], image: np.ndarray) -> None:
    """Write an RGB (or grey) uint8 image as PNG, atomically."""
    bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image
    ok, data = cv2.imencode(".png", bgr)
    if not ok:
        raise MiketalkError(f"cannot encode {path} as PNG")
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.tobytes())
