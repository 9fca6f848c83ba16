"""Frames read when they are needed: a video's, or a folder of images', as a sequence.

A full-resolution background (``say --background VIDEO``, ``dub``, a model's own frames at
HD) is played frame by frame, mostly forwards, sometimes backwards (the ping-pong loop).
Holding all of it would make memory grow with the video's pixels and length (10 s of
1080p is 1.9 GB); :class:`VideoFrames` and :class:`ImageFrames` hold a few frames:

- :class:`VideoFrames` streams the video through ffmpeg
  (:func:`~miketalk.media.decode.iter_video_frames`) and keeps the last ``keep`` frames
  read; a frame before those reopens the stream at the start and decodes on to ``keep``
  frames before it (not a seek: a seek into GRID's MPEG-1 decodes other pixels than
  reading on does), so that playing backwards costs one reading per ``keep`` frames.
- :class:`ImageFrames` reads image files, keeping the last ``keep`` read.

Both index like a read-only ``(N, H, W, 3)`` array by a whole number, and say their
``shape``.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["KEEP_BYTES", "ImageFrames", "RgbFrames", "VideoFrames", "decodes_to_i420", "played"]

#: The most bytes of frames a :class:`VideoFrames` keeps (at least 2 frames): 32 frames
#: of 1080p (6.2 MB each), 10 of 4K (24.9 MB), instead of 32 of any size (800 MB at 4K).
KEEP_BYTES = 256 << 20


class _Cached:
    """The last ``keep`` frames by index, and the sequence protocol over them."""

    def __init__(self, count: int, shape: tuple[int, int], keep: int) -> None:
        if count < 1:
            raise MiketalkError("a frame sequence needs at least one frame")
        self._count = int(count)
        self._frame_shape = (int(shape[0]), int(shape[1]))
        self._keep = max(1, int(keep))
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """``(N, H, W, 3)``."""
        return (self._count, *self._frame_shape, 3)

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[np.ndarray]:
        for i in range(self._count):
            yield self[i]

    def __getitem__(self, index):
        if isinstance(index, slice):
            return _Slice(self, range(self._count)[index])
        if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
            raise TypeError(f"frames are indexed by a whole number, not {index!r}")
        i = int(index) + (self._count if index < 0 else 0)
        if not 0 <= i < self._count:
            raise IndexError(f"frame {index} of {self._count}")
        if i in self._cache:
            self._cache.move_to_end(i)
            return self._cache[i]
        return self._read(i)

    def _remember(self, i: int, frame: np.ndarray) -> None:
        frame.flags.writeable = False
        self._cache[i] = frame
        self._cache.move_to_end(i)
        while len(self._cache) > self._keep:
            self._cache.popitem(last=False)

    def _read(self, i: int) -> np.ndarray:
        raise NotImplementedError


class _Slice:
    """Some of a sequence's frames (a slice of it), read through it."""

    def __init__(self, frames: _Cached, indices: range) -> None:
        self._frames, self._indices = frames, indices

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """``(N, H, W, 3)``."""
        return (len(self._indices), *self._frames.shape[1:])

    def __len__(self) -> int:
        return len(self._indices)

    def __iter__(self) -> Iterator[np.ndarray]:
        for i in self._indices:
            yield self._frames[i]

    def __getitem__(self, index):
        if isinstance(index, slice):
            return _Slice(self._frames, self._indices[index])
        return self._frames[self._indices[index]]


class ImageFrames(_Cached):
    """Image files as frames, read when asked for (the last ``keep`` kept).

    Parameters
    ----------
    paths : sequence of path
        One image per frame, in order, all of one size.
    keep : int
        Frames kept in memory.
    """

    def __init__(self, paths: Sequence[str | os.PathLike[str]], *, keep: int = 4) -> None:
        from miketalk.media.images import read_image

        self._paths = [Path(p) for p in paths]
        if not self._paths:
            raise MiketalkError("no image files to read frames from")
        first = read_image(self._paths[0])
        super().__init__(len(self._paths), first.shape[:2], keep)
        self._remember(0, first)

    def read_file(self, i: int) -> np.ndarray:
        """Frame ``i`` read from its file, not kept (any thread may call it).

        Raises
        ------
        MiketalkError
            A file that cannot be read, or not of the first one's size.
        """
        from miketalk.media.images import read_image

        frame = read_image(self._paths[i])
        if frame.shape[:2] != self._frame_shape:
            raise MiketalkError(
                f"{self._paths[i]} is {frame.shape[1]}x{frame.shape[0]}, the frames before it "
                f"{self._frame_shape[1]}x{self._frame_shape[0]}"
            )
        return frame

    def _read(self, i: int) -> np.ndarray:
        frame = self.read_file(i)
        self._remember(i, frame)
        return frame


class VideoFrames(_Cached):
    """A video's frames (``count`` of them from ``start``), decoded when asked for.

    Parameters
    ----------
    path : str or os.PathLike
        Any video ffmpeg reads.
    count : int
        How many frames (from ``start``).
    fps : float
        Its frame rate (where frame ``i`` starts: ``start + i / fps``).
    start : float
        Seconds from the beginning of the file.
    keep : int
        Frames kept in memory (a step back within them reads nothing), at most
        :data:`KEEP_BYTES` of them (and at least 2).
    i420 : bool
        Frames as ``(H * 3 // 2, W)`` ``yuv420p`` planes (:mod:`miketalk.media.yuv`; the
        decoder's own where :func:`decodes_to_i420`), not RGB.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        count: int,
        fps: float,
        start: float = 0.0,
        keep: int = 32,
        i420: bool = False,
    ) -> None:
        from miketalk.media.decode import video_info

        self._path = Path(path)
        width, height, _ = video_info(self._path)
        keep = min(int(keep), max(2, KEEP_BYTES // (width * height * 3)))
        super().__init__(count, (height, width), keep)
        self._fps = float(fps)
        self._start = float(start)
        self._i420 = bool(i420)
        self._stream: Iterator[np.ndarray] | None = None
        self._next = 0  # the index the open stream yields next

    @property
    def shape(self) -> tuple[int, ...]:
        """``(N, H, W, 3)``; with ``i420``, ``(N, H * 3 // 2, W)``."""
        n, h, w, _ = super().shape
        return (n, h * 3 // 2, w) if self._i420 else (n, h, w, 3)

    def _open(self) -> None:
        from miketalk.media.decode import iter_video_frames

        self.close()
        start = self._start if self._start > 0 else None
        self._stream = iter_video_frames(
            self._path, start=start, frames=self._count, i420=self._i420
        )
        self._next = 0

    def _read(self, i: int) -> np.ndarray:
        if self._stream is None or i < self._next:
            self._open()
        assert self._stream is not None
        while self._next < i - self._keep + 1:  # on to the frames worth keeping
            try:
                next(self._stream)
            except StopIteration:
                break
            self._next += 1
        while self._next <= i:
            try:
                frame = next(self._stream)
            except StopIteration:
                raise MiketalkError(
                    f"{self._path} ended at frame {self._next} of the {self._count} expected"
                ) from None
            self._remember(self._next, frame)
            self._next += 1
        return self._cache[i]

    def close(self) -> None:
        """Stop the decoder (it is started again when a frame is asked for)."""
        if self._stream is not None:
            self._stream.close()  # type: ignore[attr-defined]
            self._stream = None

    def __del__(self) -> None:
        self.close()


def decodes_to_i420(path: str | os.PathLike[str]) -> bool:
    """Whether ``path``'s frames decode to the encoder's own colours as they are: 8-bit 4:2:0
    planes in limited range and BT.601 or no stated colour space
    (:func:`~miketalk.media.ffmpeg_log.plain_i420`), of an even size."""
    from miketalk.media.decode import video_info, video_log

    width, height, _ = video_info(path)
    return video_log(path).i420 and width % 2 == 0 and height % 2 == 0


class RgbFrames:
    """A sequence of I420 frames (:class:`VideoFrames` with ``i420``) indexed as RGB: each
    a :class:`~miketalk.media.yuv.RgbOfI420`, converted only where it is read."""

    def __init__(self, planes: VideoFrames) -> None:
        self.planes = planes

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """``(N, H, W, 3)``."""
        n, h2, w = self.planes.shape
        return (n, h2 * 2 // 3, w, 3)

    def __len__(self) -> int:
        return len(self.planes)

    def __iter__(self) -> Iterator:
        for i in range(len(self)):
            yield self[i]

    def __getitem__(self, index: int):
        from miketalk.media.yuv import RgbOfI420

        return RgbOfI420(self.planes[index])


def played(
    path: str | os.PathLike[str], *, count: int, fps: float, start: float = 0.0
) -> tuple[VideoFrames | RgbFrames, VideoFrames | None]:
    """A video's frames to play a mouth into: ``(frames, i420)``, the second its
    ``yuv420p`` planes when they are the decoder's own (:func:`decodes_to_i420`; the
    frames then the same planes read as RGB where read: :class:`RgbFrames`), else None
    (the frames RGB, as ffmpeg converts them). The parameters are :class:`VideoFrames`'s.
    """
    if not decodes_to_i420(path):
        return VideoFrames(path, count=count, fps=fps, start=start), None
    planes = VideoFrames(path, count=count, fps=fps, start=start, i420=True)
    return RgbFrames(planes), planes
