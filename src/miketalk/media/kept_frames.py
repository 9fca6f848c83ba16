"""Image files decoded once and kept decoded: a model's background frames, read as played.

A model keeps its person's background as PNG frames (:mod:`miketalk.model.background`);
decoding them is most of what playing them costs (a 720p PNG: 15 to 25 ms, as long as
drawing the frame), and every ``miketalk say`` would decode the same files again.
:func:`kept_frames` decodes them once, into the user's cache
(:mod:`miketalk.media.user_cache`, kind :data:`KIND`), as two raw arrays: the frames in
RGB and in the encoder's colours (I420, :mod:`miketalk.media.yuv`, for a frame of even
size); each later run maps them from there (``numpy.load(mmap_mode="r")``): a frame costs
a copy from the page cache, and memory does not grow with the frames' pixels.

The entry is named by what the frames are: each file's size and SHA-256 as the model's
manifest records them (checked when the model was opened), else each file's path, size,
times and inode. It is written whole and then renamed (a reader never finds half of one);
one that cannot be read, or whose shape is not the frames', is made again. Without a cache
(none can be made, or ``$MIKETALK_CACHE=off``) the files are read as before, each when
first played (:class:`~miketalk.media.frame_source.ImageFrames`).
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_paths
from miketalk.media.frame_source import ImageFrames
from miketalk.media.user_cache import cache_dir, entry_name

__all__ = ["KIND", "KeptFrames", "kept_arrays", "kept_frames"]

log = logging.getLogger(__name__)

#: The kind of cache entry (:func:`~miketalk.media.user_cache.cache_dir`) of decoded frames.
KIND = "frames"

#: Threads decoding the files the first time (PNG decoding runs without the GIL).
DECODE_THREADS = max(1, min(4, os.cpu_count() or 1))


@dataclass(frozen=True)
class KeptFrames:
    """Frames decoded once and mapped from the cache.

    Attributes
    ----------
    rgb : numpy.ndarray
        ``(N, H, W, 3)`` uint8, read-only (memory-mapped).
    i420 : numpy.ndarray or None
        ``(N, H * 3 // 2, W)`` uint8, each frame's I420 planes (None for an odd size).
    """

    rgb: np.ndarray
    i420: np.ndarray | None


def kept_frames(
    paths: Sequence[str | os.PathLike[str]], *, identity: Sequence | None = None
) -> KeptFrames | ImageFrames:
    """The frames of the image files ``paths`` (all of one size), decoded once and kept.

    Parameters
    ----------
    paths : sequence of path-like
        One image per frame, in order.
    identity : sequence, optional
        What the files are, one item per file (the manifest's ``{"size", "sha256"}``);
        None: each file's path, size, times and inode.

    Returns
    -------
    KeptFrames or ImageFrames
        The kept frames; without a cache, the files read when played.

    Raises
    ------
    MiketalkError
        A file that cannot be read, or not of the first one's size.
    """
    paths = [Path(p) for p in paths]
    where = cache_dir(KIND)
    if where is None or not paths:
        return ImageFrames(paths, keep=len(paths))
    if identity is None:
        identity = [_stat(p) for p in paths]
    name = entry_name("frames/1", [str(i) for i in identity])
    rgb_path, i420_path = where / f"{name}.rgb.npy", where / f"{name}.i420.npy"
    found = _load(rgb_path, i420_path, len(paths))
    if found is not None:
        return found
    _decode(paths, rgb_path, i420_path)
    found = _load(rgb_path, i420_path, len(paths))
    return found if found is not None else ImageFrames(paths, keep=len(paths))


def _stat(path: Path) -> tuple:
    st = os.stat(path)
    return (os.path.realpath(path), st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino)


def _load(rgb_path: Path, i420_path: Path, count: int) -> KeptFrames | None:
    """The entry's arrays, mapped (None: no whole entry of ``count`` frames)."""
    try:
        rgb = np.load(rgb_path, mmap_mode="r")
        i420 = np.load(i420_path, mmap_mode="r") if i420_path.is_file() else None
    except (OSError, ValueError):
        return None
    if rgb.dtype != np.uint8 or rgb.ndim != 4 or rgb.shape[0] != count or rgb.shape[3] != 3:
        return None
    h, w = rgb.shape[1:3]
    if i420 is not None and (i420.dtype != np.uint8 or i420.shape != (count, h * 3 // 2, w)):
        return None
    if i420 is None and h % 2 == 0 and w % 2 == 0:
        return None  # an even frame's I420 belongs to the entry
    return KeptFrames(rgb, i420)


def _decode(paths: list[Path], rgb_path: Path, i420_path: Path) -> None:
    """Decode ``paths`` into the entry, written in order as they are decoded (a full disk
    is an error of a write, never a fault of a mapped page); whole or not at all: a cache
    that cannot be written keeps nothing, a file that cannot be decoded is an error."""
    from miketalk.media.yuv import to_i420

    reader = ImageFrames(paths, keep=1)  # each file checked against the first's size
    h, w = reader.shape[1:3]
    even = h % 2 == 0 and w % 2 == 0
    targets = [rgb_path, i420_path] if even else [rgb_path]
    shapes = [(len(paths), h, w, 3), (len(paths), h * 3 // 2, w)]

    def one(i: int) -> tuple[np.ndarray, np.ndarray | None]:
        try:
            frame = reader.read_file(i)
        except MiketalkError as err:
            raise _Unreadable(err) from None
        return frame, (to_i420(frame) if even else None)

    try:
        with (
            atomic_paths(targets, suffixes=[".npy"] * len(targets)) as tmps,
            contextlib.ExitStack() as stack,
        ):
            files = [stack.enter_context(open(t, "wb")) for t in tmps]
            for f, shape in zip(files, shapes, strict=False):
                header = {"descr": "|u1", "fortran_order": False, "shape": shape}
                np.lib.format.write_array_header_1_0(f, header)
            with ThreadPoolExecutor(DECODE_THREADS, thread_name_prefix="miketalk-decode") as pool:
                for decoded in pool.map(one, range(len(paths))):
                    for f, array in zip(files, decoded, strict=False):
                        f.write(np.ascontiguousarray(array).data)
    except _Unreadable as err:
        raise err.error from None
    except (OSError, MiketalkError) as err:  # a full disk, a cache removed meanwhile
        log.debug("decoded frames not kept (%s)", err)


class _Unreadable(Exception):
    """A file that cannot be decoded (its error is the caller's, not the cache's)."""

    def __init__(self, error: MiketalkError) -> None:
        super().__init__(str(error))
        self.error = error


def kept_arrays(kind: str, identity: object, make) -> tuple[np.ndarray, ...] | None:
    """Arrays made once by ``make()`` (a tuple of arrays) and kept in the user's cache
    under ``kind``, named by ``identity`` (what they are made from: a file's size and
    SHA-256 in a model's manifest); the next run reads them back instead of making them
    (a model's flows: an OpenEXR file's parsing and checks, 4 ms a flow of s1, against a
    raw read). Each array is read whole (writable, not mapped). None: ``make()``'s arrays
    could not be kept nor read (no cache); the caller makes them itself.
    """
    where = cache_dir(kind)
    if where is None:
        return None
    path = where / f"{entry_name(kind + '/1', str(identity))}.npz"
    try:
        with np.load(path) as found:
            return tuple(found[f"arr_{i}"] for i in range(len(found.files)))
    except (OSError, ValueError, KeyError):
        pass
    arrays = tuple(make())
    try:
        with atomic_paths([path], suffixes=[".npz"]) as (tmp,), open(tmp, "wb") as f:
            np.savez(f, *arrays)
    except (OSError, MiketalkError) as err:
        log.debug("%s not kept (%s)", kind, err)
    return arrays
