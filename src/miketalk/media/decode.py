"""Decoding video files with the ffmpeg binary bundled with imageio-ffmpeg: their frames (a
media file's sound: :func:`miketalk.media.audio.read_media_audio`, also importable here).

:func:`read_video` decodes a video file to RGB frames (:func:`iter_video_frames` streams
them, or their ``yuv420p`` planes). ffmpeg is run with an argument list, never through a
shell.

:func:`read_video` runs ffmpeg once, with the decoder, the filter graph and the
colour conversion on one thread each (``-threads 1 -filter_threads 1``) and
every decoded frame passed through as it is (``-fps_mode passthrough``: no
frame dropped or repeated to fit a constant rate), so the same file gives the
same bytes on every run and machine. The colour conversion is BT.601
limited-range YUV to full-range RGB with full-resolution chroma interpolation
and accurate rounding (``-sws_flags bicubic+accurate_rnd+full_chroma_int``).

The frame rate is the stream's own rational rate as ffmpeg's filter graph
receives it (``fr:25/1`` in ffmpeg's verbose log), not the rounded figure of
its summary line: an NTSC stream gives 30000/1001 exactly (as a float).

A variable-frame-rate video (a phone's recording, a screen capture, clips of
different rates joined) is read by its frames' timestamps instead: the first
time a file is read, its video packets' timestamps are listed (``-c copy -f
framemd5``: nothing decoded), and when the frames do not span ``frames / rate``
seconds (within :data:`SLACK_FRAMES` frames), or the stream states no rate, the
file is decoded at its average rate R (its frames over the seconds they span),
constant: ffmpeg's fps filter (``fps=R:round=up:start_time=0``) makes frame k
the one on screen at ``k / R``, so frames are repeated where they came slower
and dropped where they came faster, and the sound, decoded by its own
timestamps, stays in sync. A part from ``start`` is the same frames as the whole
read's: the seek keeps the frames before ``start`` (``-noaccurate_seek``, the
filter picks the one on screen), and ``start`` is rounded up to ffmpeg's
microsecond. One warning says so; R is the rate :func:`read_video` returns. What
each file was found to be is remembered for the process (by its path, size and
modification time).

Every ffmpeg runs as a :func:`miketalk.console.child_process`: a signal that
stops the run kills it at once, so the threads decoding clips for the corpus
return at once instead of keeping the stopped run alive, and start no other.
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
import threading
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

from miketalk.console import child_process
from miketalk.errors import MiketalkError
from miketalk.media.audio import read_media_audio  # a media file's sound, here too
from miketalk.media.ffmpeg_log import RATE_RE as _RATE_RE
from miketalk.media.ffmpeg_log import SIZE_RE as _SIZE_RE
from miketalk.media.ffmpeg_log import TV_TO_FULL, Logged, unreadable, warn_if_early_end
from miketalk.media.timing import resample_rate

__all__ = [
    "COLOUR_CONVERSIONS",
    "SLACK_FRAMES",
    "iter_video_frames",
    "read_media_audio",
    "read_video",
    "stated_seconds",
    "video_info",
    "video_log",
]

log = logging.getLogger(__name__)

#: Frames (of the stated rate) by which the frames' timestamps may span more or less
#: than ``frames / rate`` before the video counts as having a variable frame rate.
SLACK_FRAMES = 1.5

#: swscale's flags for the colour conversion to RGB, by name. ``accurate`` is every
#: whole frame's (:func:`read_video`); ``fast`` leaves out the accurate rounding, which
#: puts swscale on a path 4 times slower (a 706x648 region of a 1080p frame: about 3.4 ms
#: against 0.9 ms), for RGB 1.1 to 1.3 levels darker on average (up to 29 levels in
#: places, at strong colour edges); ``bitexact`` keeps its output the same on every CPU.
COLOUR_CONVERSIONS = {
    "accurate": "bicubic+accurate_rnd+full_chroma_int",
    "fast": "bicubic+full_chroma_int+bitexact",
}


def read_video(
    path: str | os.PathLike[str], *, start: float | None = None, frames: int | None = None
) -> tuple[np.ndarray, float]:
    """Decode every frame of the first video stream of ``path`` (or ``frames`` from ``start``).

    A video with a variable frame rate is decoded at its average rate, constant, by its
    frames' timestamps (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        Any video file ffmpeg reads (GRID's MPEG-1 ``.mpg``, mp4, ...). Audio
        streams are ignored.
    start : float, optional
        Seconds from the beginning: decode from the first frame shown at or
        after it (ffmpeg's accurate input seek).
    frames : int, optional
        Decode at most this many frames.

    Returns
    -------
    frames : numpy.ndarray
        ``(N, H, W, 3)`` uint8 RGB, in display order; ``H, W`` the stream's
        stored size (after any rotation the file asks for).
    fps : float
        The stream's frame rate (25.0 for GRID); for a variable frame rate, the
        constant rate it was decoded at.

    Raises
    ------
    MiketalkError
        If the file is missing, ffmpeg cannot decode it, it has no video
        stream, no frame decodes, or its frame rate is unknown (stated by
        neither the stream nor its timestamps).
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"video file not found: {path}")
    known = _constant_rates.get(_file_key(path), _UNKNOWN)
    resample = None if known is _UNKNOWN else known
    args = _video_args(path, "verbose", start, frames, resample)
    code, out, err = _run(args)
    log_text = err.decode("utf-8", "replace")
    if code != 0:
        if "matches no streams" in log_text:
            raise MiketalkError(f"{path} has no video stream")
        raise unreadable(path, log_text)
    size = _SIZE_RE.search(log_text)
    rate = _RATE_RE.search(log_text)
    if size is None or not out:
        raise unreadable(path, log_text, decoded=False)
    width, height = int(size[1]), int(size[2])
    _logged[_file_key(path)] = Logged.of(log_text)
    stated = None
    if rate is not None and int(rate[1]) != 0 and int(rate[2]) != 0:
        stated = Fraction(int(rate[1]), int(rate[2]))
    if known is _UNKNOWN:
        resample = _constant_rate(path, stated)
        if resample is not None:  # decoded at the stated pace: again, by the timestamps
            return read_video(path, start=start, frames=frames)
    fps = resample if resample is not None else stated
    if fps is None:
        raise MiketalkError(f"{path}: the video stream does not state its frame rate")
    frame_bytes = width * height * 3
    if len(out) % frame_bytes:
        raise MiketalkError(
            f"{path}: ffmpeg's output ({len(out)} bytes) is not a whole number of "
            f"{width}x{height} RGB frames"
        )
    decoded = np.frombuffer(out, np.uint8).reshape(-1, height, width, 3).copy()
    if start is None and frames is None:  # the whole video: does it end where it says?
        warn_if_early_end(path, len(decoded), float(fps), _logged[_file_key(path)].duration)
    return decoded, float(fps)


def _video_args(
    path: Path,
    loglevel: str,
    start: float | None,
    frames: int | None,
    resample: Fraction | None = None,
    *,
    grey: bool = False,
    luma_plane: bool = False,
    region: tuple[int, int, int, int] | None = None,
    conversion: str = "accurate",
    i420: bool = False,
) -> list[str]:
    """ffmpeg's arguments decoding ``path``'s first video stream to raw RGB (or grey, or
    ``yuv420p`` with ``i420``) on its stdout (every frame as it is, or at the constant rate
    ``resample``; only ``region``; with ``luma_plane``, the grey frames are the stream's luma
    plane as stored; the RGB by ``conversion``'s flags, :data:`COLOUR_CONVERSIONS`)."""
    import imageio_ffmpeg

    seek, pace = (["-ss", f"{start:.6f}"] if start else []), []
    if resample is not None:  # frame k: the one on screen at k / resample (module docstring)
        pace = [f"fps={resample}:round=up:start_time=0"]
        if start:  # the frames before start kept for the filter; start not before k / rate
            seek = ["-noaccurate_seek", "-ss", f"{math.ceil(start * 1e6 - 1e-6) / 1e6:.6f}"]
    if region is not None:
        pace.append("crop={2}:{3}:{0}:{1}:exact=1".format(*region))
    if luma_plane:
        pace.append("extractplanes=y")
    return [
        imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-loglevel", loglevel,
        "-threads", "1", *seek, "-i", str(path),
        *(["-frames:v", str(int(frames))] if frames is not None else []),
        "-map", "0:v:0", "-an", "-sn", "-dn", *(["-vf", ",".join(pace)] if pace else []),
        "-fps_mode", "passthrough", "-filter_threads", "1",
        "-sws_flags", COLOUR_CONVERSIONS[conversion], "-threads", "1",
        "-f", "rawvideo", "-pix_fmt", "gray" if grey else "yuv420p" if i420 else "rgb24",
        "pipe:1",
    ]  # fmt: skip


def video_info(path: str | os.PathLike[str]) -> tuple[int, int, float]:
    """The width, height and frame rate of the first video stream of ``path``.

    Found by decoding its first frame as :func:`read_video` does (so the size is the one
    :func:`iter_video_frames` yields), once per file for the process (by its path, size and
    modification time: a 1080p file's costs ffmpeg 0.1 s of CPU, and every clip of a video
    read for the corpus asked three times).

    Parameters
    ----------
    path : str or os.PathLike
        Any video file ffmpeg reads.

    Returns
    -------
    width, height : int
        The decoded frames' size in pixels.
    fps : float
        The stream's frame rate.

    Raises
    ------
    MiketalkError
        As :func:`read_video`.
    """
    try:
        key = _file_key(Path(path))
    except OSError:  # not there: read_video says so
        key = None
    info = _infos.get(key) if key else None
    if info is None:
        first, fps = read_video(path, frames=1)
        info = int(first.shape[2]), int(first.shape[1]), fps
        if key:
            _infos[key] = info
    return info


def stated_seconds(path: str | os.PathLike[str]) -> float | None:
    """The seconds a video's container states it lasts (None: it does not say)."""
    return video_log(path).duration


def video_log(path: str | os.PathLike[str]) -> Logged:
    """What ffmpeg's log said of ``path``'s video (its first frame read once)."""
    video_info(path)
    return _logged.get(_file_key(Path(path)), Logged(None, None))


def iter_video_frames(
    path: str | os.PathLike[str],
    *,
    start: float | None = None,
    frames: int | None = None,
    grey: bool = False,
    region: tuple[int, int, int, int] | None = None,
    conversion: str = "accurate",
    i420: bool = False,
) -> Iterator[np.ndarray]:
    """Decode the first video stream of ``path`` one frame at a time, as a stream.

    The same frames as :func:`read_video` (the same ffmpeg arguments, so the same
    bytes), but memory holds one frame, not the whole video: a long HD video is
    read in constant memory. ffmpeg runs while the frames are consumed; closing the
    generator early (``break``, ``close()``) stops it. ``grey`` and ``region`` make
    ffmpeg convert less than every pixel to RGB (the conversion, not the decoding, is
    most of its work at 1080p: 12 ms a frame, the decoding 3 ms). Grey frames of 8-bit
    planar YUV are the luma plane as stored, mapped to full range here: the same bytes
    as ffmpeg's grey conversion, which costs 1.1 ms more a 1080p frame.

    Parameters
    ----------
    path : str or os.PathLike
        Any video file ffmpeg reads.
    start : float, optional
        Seconds from the beginning (ffmpeg's accurate input seek), as :func:`read_video`.
    frames : int, optional
        Yield at most this many frames.
    grey : bool
        Yield ``(H, W)`` grey frames (the stream's luma, full range) instead.
    region : tuple of int, optional
        ``(x, y, w, h)``: only that part of each frame (ffmpeg's ``crop`` before the
        colour conversion; with ``x`` and ``y`` even, its pixels 3 or more from the
        region's edges inside the frame are the whole frame's, byte for byte).
    conversion : str
        The RGB conversion's name in :data:`COLOUR_CONVERSIONS` (``accurate``: the bytes
        of :func:`read_video`).
    i420 : bool
        Yield whole frames' ``(H * 3 // 2, W)`` ``yuv420p`` planes instead.

    Yields
    ------
    numpy.ndarray
        ``(H, W, 3)`` uint8 RGB frames in display order (each a new array).

    Raises
    ------
    MiketalkError
        If the file is missing or ffmpeg cannot decode it (before the first frame, from
        :func:`video_info`, or when the stream ends, quoting ffmpeg's log), or if the
        stream ends inside a frame.
    """
    path = Path(path)
    width, height, fps = video_info(path)
    if region is not None:
        width, height = region[2], region[3]
    if i420 and (grey or region is not None or width % 2 or height % 2):
        raise MiketalkError("yuv420p frames are whole frames of an even size, in colour")
    shape = (height, width) if grey else (height * 3 // 2, width) if i420 else (height, width, 3)
    frame_bytes = math.prod(shape)
    key = _file_key(path)
    rate = _constant_rates.get(key)
    logged = _logged.get(key, Logged(None, None))
    luma = logged.luma if grey else None
    lut = TV_TO_FULL if luma == "tv" else None
    args = _video_args(
        path, "error", start, frames, rate, grey=grey, luma_plane=luma is not None,
        region=region, conversion=conversion, i420=i420,
    )  # fmt: skip
    count = 0
    with tempfile.TemporaryFile() as errors:
        with child_process(args, stderr=errors) as proc:  # killed if the consumer stops early
            assert proc.stdout is not None
            while True:
                data = proc.stdout.read(frame_bytes)
                if not data:
                    break
                if len(data) < frame_bytes:
                    raise MiketalkError(
                        f"{path}: the video stream ended inside a {width}x{height} frame"
                    )
                frame = np.frombuffer(data, np.uint8).reshape(shape)
                count += 1
                yield frame.copy() if lut is None else cv2.LUT(frame, lut)
        if proc.returncode != 0:
            errors.seek(0)
            raise unreadable(path, errors.read().decode("utf-8", "replace"))
    if start is None and frames is None:
        warn_if_early_end(path, count, rate or fps, logged.duration)


# ---------------------------------------------------------------------------
# the frames' timestamps: a variable frame rate read at a constant one
# ---------------------------------------------------------------------------

_UNKNOWN = object()
#: Per file (:func:`_file_key`): the constant rate its frames are read at, or None
#: when they are read as they are (their timestamps follow the stated rate).
_constant_rates: dict[tuple[str, int, int], Fraction | None] = {}
_constant_rates_lock = threading.Lock()
#: Per file: its :func:`video_info`.
_infos: dict[tuple[str, int, int], tuple[int, int, float]] = {}
#: Per file: what its reads logged of it.
_logged: dict[tuple[str, int, int], Logged] = {}


def _file_key(path: Path) -> tuple[str, int, int]:
    """What names one version of a file: its real path, size and modification time."""
    info = path.stat()
    return str(path.resolve()), info.st_size, info.st_mtime_ns


def _constant_rate(path: Path, stated: Fraction | None) -> Fraction | None:
    """The rate ``path``'s frames are to be read at, or None: they follow ``stated``.

    Found once per file (see the module docstring) and warned about when the frames
    are resampled.
    """
    key = _file_key(path)
    with _constant_rates_lock:
        if key not in _constant_rates:
            _constant_rates[key] = resample_rate(path, stated, SLACK_FRAMES, _run)
        return _constant_rates[key]


def _run(args: list[str], *, timeout: float | None = None) -> tuple[int, bytes, bytes]:
    """ffmpeg run with ``args`` to its end: its exit status, stdout and stderr.

    A signal stopping the run kills it (:func:`miketalk.console.child_process`).

    Raises
    ------
    subprocess.TimeoutExpired
        When it runs longer than ``timeout`` seconds (it is killed).
    MiketalkError
        Outside the main thread once the run is stopping: nothing is started.
    """
    with child_process(args) as proc:
        out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out, err
