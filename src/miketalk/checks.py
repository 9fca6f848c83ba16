"""Entry checks of images and flows, one rule each, shared by the flow package and the morph.

Images are ``(H, W)`` or ``(H, W, 3)``, uint8 or float; flows are float ``(H, W, 2)``
(an integer array is not a flow) and finite. Also the greyscale conversions the
estimators share.
"""

from __future__ import annotations

import cv2
import numpy as np

from miketalk.errors import MiketalkError

_GREY_WEIGHTS = np.array([0.299, 0.587, 0.114], dtype=np.float32)  # ITU-R BT.601 luma


def check_image(image: np.ndarray, name: str, *, uint8_only: bool = False) -> np.ndarray:
    """Return ``image`` as an array after checking it is a finite grey or RGB image.

    Parameters
    ----------
    image : array_like
        ``(H, W)`` or ``(H, W, 3)``, uint8 (0-255) or float (0-1).
    name : str
        The argument name used in error messages.
    uint8_only : bool
        Accept uint8 only (the morph's kernels work on 8-bit pixels).

    Raises
    ------
    MiketalkError
        Naming ``name`` if the array is not ``(H, W)`` or ``(H, W, 3)``, not
        uint8/float, or holds NaN or inf.
    """
    if not isinstance(image, np.ndarray):
        raise MiketalkError(f"{name} must be a numpy array, got {type(image).__name__}")
    if uint8_only and image.dtype != np.uint8:
        raise MiketalkError(
            f"{name} must be uint8 (0-255), got dtype {image.dtype}; "
            "convert it with skimage.util.img_as_ubyte"
        )
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3):
        raise MiketalkError(
            f"{name} must be an (H, W) grey or (H, W, 3) RGB image, got shape {image.shape}"
        )
    if image.shape[0] < 1 or image.shape[1] < 1:
        raise MiketalkError(f"{name} is empty (shape {image.shape})")
    if image.dtype != np.uint8 and not np.issubdtype(image.dtype, np.floating):
        raise MiketalkError(
            f"{name} must be uint8 (0-255) or float (0-1), got dtype {image.dtype}; "
            "convert it with skimage.util.img_as_float32 or img_as_ubyte"
        )
    if image.dtype != np.uint8 and not np.isfinite(image).all():
        raise MiketalkError(f"{name} holds NaN or inf values")
    return image


def check_pair(image_a: np.ndarray, image_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Check two images for an estimator: each valid, same shape, same dtype.

    Raises
    ------
    MiketalkError
        Naming ``image_a`` or ``image_b``.
    """
    a = check_image(image_a, "image_a")
    b = check_image(image_b, "image_b")
    if a.shape[0] < 2 or a.shape[1] < 2:
        raise MiketalkError(f"image_a must be at least 2x2 pixels, got shape {a.shape}")
    if a.shape != b.shape:
        raise MiketalkError(
            f"image_b has shape {b.shape} but image_a has shape {a.shape}; "
            "flow is estimated between images of the same size"
        )
    if a.dtype != b.dtype:
        raise MiketalkError(
            f"image_b has dtype {b.dtype} but image_a has dtype {a.dtype}; "
            "give both images the same dtype"
        )
    return a, b


def check_flow(flow: np.ndarray, name: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Return ``flow`` as float32 after checking it is a finite ``(H, W, 2)`` field.

    Parameters
    ----------
    flow : ndarray
        The flow to check.
    name : str
        The argument name used in error messages.
    shape : (int, int), optional
        The required ``(H, W)``.

    Raises
    ------
    MiketalkError
        Naming ``name``.
    """
    if not isinstance(flow, np.ndarray):
        raise MiketalkError(f"{name} must be a numpy array, got {type(flow).__name__}")
    if flow.ndim != 3 or flow.shape[2] != 2:
        raise MiketalkError(f"{name} must be an (H, W, 2) flow field, got shape {flow.shape}")
    if not np.issubdtype(flow.dtype, np.floating):
        raise MiketalkError(f"{name} must be a float flow field, got dtype {flow.dtype}")
    if shape is not None and flow.shape[:2] != tuple(shape):
        raise MiketalkError(
            f"{name} has size {flow.shape[:2]} but {tuple(shape)} is required; "
            "a flow belongs to the images it was computed on"
        )
    if not np.isfinite(flow).all():
        raise MiketalkError(f"{name} holds NaN or inf values")
    return flow.astype(np.float32, copy=False)


def to_grey_float32(image: np.ndarray) -> np.ndarray:
    """Grey float32 version of a checked image: uint8 scaled to [0, 1], floats kept as they are."""
    if image.ndim == 3:
        grey = image.astype(np.float32, copy=False) @ _GREY_WEIGHTS
    else:
        grey = image.astype(np.float32)
    if image.dtype == np.uint8:
        grey *= np.float32(1.0 / 255.0)
    return np.ascontiguousarray(grey, dtype=np.float32)


def to_grey_uint8(image: np.ndarray) -> np.ndarray:
    """Grey uint8 version of a checked image, for the OpenCV estimators that need 8 bits.

    uint8 RGB goes through ``cv2.cvtColor`` (BT.601, rounded); float images in
    [0, 1] are scaled by 255, rounded and clipped.
    """
    if image.dtype == np.uint8:
        if image.ndim == 2:
            return np.ascontiguousarray(image)
        return cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY)
    grey = to_grey_float32(image) * np.float32(255.0)
    return np.clip(np.rint(grey), 0, 255).astype(np.uint8)
