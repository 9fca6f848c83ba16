"""Frames in the encoder's own colours: planar YUV 4:2:0 (ffmpeg's ``yuv420p``, I420).

H.264 stores a frame as Y at full size and U, V at half its width and height. A frame
given to ffmpeg as RGB is converted whole, every pixel, on the encoder's core. A talking
face changes only the mouth's box of a background frame: the background can be converted
once (and kept, :mod:`miketalk.media.kept_frames`) and each output frame converted only
over the box (:func:`paste_rgb`), so the encoder reads ``yuv420p`` as it is, half the bytes
of RGB through the pipe, and converts nothing.

The conversion is OpenCV's ``COLOR_RGB2YUV_I420`` (BT.601, limited range, each chroma
sample from its 2x2 block): what ffmpeg's default conversion of ``rgb24`` to ``yuv420p``
computes, but for rounding (on a 720p frame of the weekly addresses: 1.7 % of Y's pixels
off by one, none by more; 2.5 % of U's and V's samples off, 0.2 % by more than one, up to 10
at sharp colour edges, where ffmpeg's chroma filter reaches beyond the 2x2 block). An mp4
made of such frames therefore differs in its bytes from one made of the same RGB frames
converted by ffmpeg, not visibly. Being local to each 2x2 block,
the conversion of a box whose corners are even equals that box of the whole frame's.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["I420Frame", "RgbOfI420", "even_box", "paste_rgb", "to_i420"]


@dataclass(frozen=True)
class I420Frame:
    """One frame as ``yuv420p`` planes.

    Attributes
    ----------
    planes : numpy.ndarray
        ``(H * 3 // 2, W)`` uint8: the Y plane's ``H`` rows, then U's and V's ``H // 4``
        rows each (their half-width rows two to a row), as ffmpeg reads ``yuv420p``.
    """

    planes: np.ndarray

    @property
    def size(self) -> tuple[int, int]:
        """``(H, W)`` of the picture."""
        return self.planes.shape[0] * 2 // 3, self.planes.shape[1]

    def rgb(self) -> np.ndarray:
        """The picture as (H, W, 3) uint8 RGB (what a player shows)."""
        return cv2.cvtColor(self.planes, cv2.COLOR_YUV2RGB_I420)


def to_i420(rgb: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` uint8 RGB, ``H`` and ``W`` even, as ``(H * 3 // 2, W)`` I420 planes.

    Raises
    ------
    MiketalkError
        An odd height or width (4:2:0 needs even ones) or not RGB uint8.
    """
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise MiketalkError(f"an RGB frame is (H, W, 3) uint8, not {rgb.shape} {rgb.dtype}")
    if rgb.shape[0] % 2 or rgb.shape[1] % 2:
        raise MiketalkError(f"a 4:2:0 frame has an even size, not {rgb.shape[1]}x{rgb.shape[0]}")
    return cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2YUV_I420)


def even_box(box: tuple[int, int, int, int], size: tuple[int, int]) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` grown to even corners (at most one pixel each way), within
    ``size`` ``(H, W)`` (even)."""
    x0, y0, x1, y1 = box
    h, w = size
    return x0 - x0 % 2, y0 - y0 % 2, min(w, x1 + x1 % 2), min(h, y1 + y1 % 2)


def paste_rgb(planes: np.ndarray, box: tuple[int, int, int, int], rgb: np.ndarray) -> None:
    """Write the RGB pixels ``rgb`` of the even ``box`` ``(x0, y0, x1, y1)`` into the I420
    ``planes`` of a frame, converted (:func:`to_i420`): as if the whole frame were."""
    x0, y0, x1, y1 = box
    if x0 % 2 or y0 % 2 or x1 % 2 or y1 % 2:
        raise MiketalkError(f"a box pasted into a 4:2:0 frame has even corners, not {box}")
    h2, w = planes.shape
    h = h2 * 2 // 3
    patch = to_i420(rgb)
    bh, bw = y1 - y0, x1 - x0
    planes[y0:y1, x0:x1] = patch[:bh]
    chroma = patch[bh:].reshape(2, bh // 2, bw // 2)
    flat = planes.reshape(-1)  # a view: U's and V's rows do not start at a row of W
    for k in range(2):  # U then V, each (H/2, W/2)
        start = h * w + k * (h // 2) * (w // 2)
        plane = flat[start : start + (h // 2) * (w // 2)].reshape(h // 2, w // 2)
        plane[y0 // 2 : y1 // 2, x0 // 2 : x1 // 2] = chroma[k]


class RgbOfI420:
    """An I420 frame read as ``(H, W, 3)`` RGB, converted only where it is read.

    ``view[y0:y1, x0:x1]`` converts that box grown to even corners (OpenCV's
    ``COLOR_YUV2RGB_I420``: BT.601 limited range, each chroma sample for its 2x2 block, so a
    box's pixels are the whole frame's, byte for byte) and ``numpy.asarray(view)`` the
    whole frame: a frame whose mouth alone is blended (:mod:`miketalk.composite`) converts
    that box, not its 0.9 million other pixels.

    Parameters
    ----------
    planes : numpy.ndarray
        ``(H * 3 // 2, W)`` uint8, ``H`` and ``W`` even (:class:`I420Frame`'s layout).
    """

    ndim = 3
    dtype = np.dtype(np.uint8)

    def __init__(self, planes: np.ndarray) -> None:
        self.planes = planes
        self.shape = (planes.shape[0] * 2 // 3, planes.shape[1], 3)

    def __getitem__(self, key):
        key = key if isinstance(key, tuple) else (key,)
        if len(key) < 2 or not all(isinstance(k, slice) and k.step in (None, 1) for k in key[:2]):
            return np.asarray(self)[key]
        h, w, _ = self.shape
        (y0, y1, _), (x0, x1, _) = key[0].indices(h), key[1].indices(w)
        y1, x1 = max(y0, y1), max(x0, x1)
        ey0, ex0, ey1, ex1 = y0 - y0 % 2, x0 - x0 % 2, y1 + y1 % 2, x1 + x1 % 2
        rgb = self._convert(ey0, ey1, ex0, ex1)[y0 - ey0 : y1 - ey0, x0 - ex0 : x1 - ex0]
        return rgb[(slice(None), slice(None), *key[2:])] if len(key) > 2 else rgb

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        rgb = self._convert(0, self.shape[0], 0, self.shape[1])
        return rgb if dtype is None else rgb.astype(dtype)

    def _convert(self, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
        """RGB of the even box ``[y0, y1) x [x0, x1)``."""
        h, w, _ = self.shape
        bh, bw = y1 - y0, x1 - x0
        if bh == 0 or bw == 0:
            return np.zeros((bh, bw, 3), np.uint8)
        flat = self.planes.reshape(-1)
        box = np.empty((bh * 3 // 2, bw), np.uint8)
        box[:bh] = self.planes[y0:y1, x0:x1]
        chroma = box[bh:].reshape(2, bh // 2, bw // 2)  # U then V, as the whole frame's
        for k in range(2):
            start = h * w + k * (h // 2) * (w // 2)
            plane = flat[start : start + (h // 2) * (w // 2)].reshape(h // 2, w // 2)
            chroma[k] = plane[y0 // 2 : y1 // 2, x0 // 2 : x1 // 2]
        return cv2.cvtColor(box, cv2.COLOR_YUV2RGB_I420)
