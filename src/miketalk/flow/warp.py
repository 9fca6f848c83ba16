"""Backward warping (the paper's Fig. 9): sample an image or a flow field along a flow."""

from __future__ import annotations

import cv2
import numpy as np

from miketalk.checks import check_flow
from miketalk.errors import MiketalkError

_MAX_REMAP_CHANNELS = 4


def backward_warp(image: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Warp ``image`` backwards along ``flow``: ``out(p) = image(p + flow(p))``.

    This is the BACKWARD WARP of the paper's Fig. 9: every output pixel ``p``
    looks up ``image`` at ``p + flow(p)`` with BILINEAR interpolation of the
    four nearest pixels. With ``flow`` the correspondence map C_0 from A to B
    (so ``A(p) ~ B(p + C_0(p))``), ``backward_warp(B, C_0)`` resamples B onto
    A's pixel grid. Warping a flow field this way is what flow concatenation
    (the paper's Eq. 11) needs to bring a field into another reference frame.

    Lookups outside the image read the nearest border pixel (OpenCV's
    ``BORDER_REPLICATE``): a flow that points past the edge keeps the edge
    value instead of inventing zeros.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        Image or field to sample: grey, RGB, or a flow field ``(H, W, 2)``.
        uint8 stays uint8 (rounded); other dtypes are interpolated in float32.
    flow : ndarray, shape (H, W, 2)
        Displacements ``(dx, dy)`` in pixels, on the output's grid.

    Returns
    -------
    ndarray
        Same shape as ``image``; uint8 if ``image`` is uint8, float32 otherwise.

    Raises
    ------
    MiketalkError
        If the shapes disagree or ``flow`` holds NaN/inf.

    Examples
    --------
    >>> import numpy as np
    >>> image = np.arange(12, dtype=np.float32).reshape(3, 4)
    >>> shift = np.zeros((3, 4, 2), np.float32); shift[..., 0] = 1.0
    >>> backward_warp(image, shift)[0]
    array([1., 2., 3., 3.], dtype=float32)
    """
    image = np.asarray(image)
    if image.ndim not in (2, 3):
        raise MiketalkError(f"image must be (H, W) or (H, W, C), got shape {image.shape}")
    flow = check_flow(flow, "flow", image.shape[:2])
    return _remap(image, flow)


def warp_in_box(image: np.ndarray, flow_in_box: np.ndarray, corner: tuple[int, int]) -> np.ndarray:
    """``_remap(image, flow)`` over one box of the output only: the same numbers, to the bit.

    ``image`` is sampled whole, as :func:`backward_warp` samples it (its borders
    replicated); ``flow_in_box`` is the warping flow over the box whose top-left corner is
    ``corner`` ``(x, y)``. OpenCV turns a relative map into positions in two ways, and each
    is followed here:

    - a flow field (two float32 channels) is warped on OpenCV's fixed-point grid: the
      relative map is rounded to 1/32 pixel before each pixel's position is added, so the
      box's map is rounded the same way (``cv2.convertMaps``) and its positions added as
      integers;
    - an image (one or three channels, uint8 or float32) is warped at the float32 sum of
      each pixel's position and its flow, made here the same way.

    Checked against the whole remap for flow fields, grey and RGB images, uint8 and float32
    (tests/product/test_flow.py).
    """
    x, y = corner
    h, w = flow_in_box.shape[:2]
    flow_in_box = np.ascontiguousarray(flow_in_box, np.float32)
    if image.dtype != np.uint8:
        image = image.astype(np.float32, copy=False)
    image = np.ascontiguousarray(image)
    if image.ndim == 3 and image.shape[2] == 2:
        whole, fraction = cv2.convertMaps(flow_in_box, None, cv2.CV_16SC2)
        grid = np.empty((h, w, 2), np.int32)
        grid[..., 0] = np.arange(x, x + w, dtype=np.int32)[None, :]
        grid[..., 1] = np.arange(y, y + h, dtype=np.int32)[:, None]
        grid += whole
        maps = (np.clip(grid, -32768, 32767).astype(np.int16), fraction)
    elif image.ndim == 2 or image.shape[2] in (1, 3):
        at = flow_in_box.copy()
        at[..., 0] += np.arange(x, x + w, dtype=np.float32)[None, :]
        at[..., 1] += np.arange(y, y + h, dtype=np.float32)[:, None]
        maps = (at, None)
    else:
        raise MiketalkError(f"warp_in_box warps 1, 2 or 3 channels, not {image.shape[2]}")
    out = cv2.remap(image, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(h, w, *image.shape[2:])


def _remap(image: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Bilinear ``image(p + flow(p))`` with replicated borders; no checks."""
    if image.dtype != np.uint8:
        image = image.astype(np.float32, copy=False)
    flags = cv2.INTER_LINEAR | cv2.WARP_RELATIVE_MAP
    if image.ndim == 3 and image.shape[2] > _MAX_REMAP_CHANNELS:
        parts = [
            _remap(image[..., i : i + _MAX_REMAP_CHANNELS], flow)
            for i in range(0, image.shape[2], _MAX_REMAP_CHANNELS)
        ]
        return np.concatenate([p.reshape(*p.shape[:2], -1) for p in parts], axis=2)
    out = cv2.remap(
        np.ascontiguousarray(image),
        np.ascontiguousarray(flow),
        None,
        flags,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return out.reshape(image.shape)
