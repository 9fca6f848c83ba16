"""Decoding media files with the ffmpeg binary bundled with imageio-ffmpeg: frames and sound.

:func:`read_video` decodes a video file to RGB frames; :func:`read_media_audio` decodes the
sound track of any media file (video or audio) to mono int16 samples. ffmpeg is run with
an argument list, never through a shell.

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
"""

from __future__ import annotations

import os
import re
import subprocess
import tempfile
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["iter_video_frames", "read_media_audio", "read_video", "video_info"]

#: Seconds ffmpeg may take to decode one file's sound.
_TIMEOUT = 300.0
_STDERR_TAIL = 6  # lines of ffmpeg's log quoted in an error
# the filter graph's input: "... w:360 h:288 pixfmt:yuv420p tb:1/90000 fr:25/1 sar:1/1 ..."
_RATE_RE = re.compile(r"input from stream \S+ @ \S+\] .*?\bfr:(\d+)/(\d+)")
# the output stream: "Stream #0:0: Video: rawvideo ... rgb24(...), 360x288 [SAR ..."
_SIZE_RE = re.compile(r"Output #0.*?Stream #0:0.*?Video: rawvideo\b.*?, (\d+)x(\d+)", re.DOTALL)


def read_video(
    path: str | os.PathLike[str], *, start: float | None = None, frames: int | None = None
) -> tuple[np.ndarray, float]:
    """Decode every frame of the first video stream of ``path`` (or ``frames`` from ``start``).

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
        The stream's frame rate (25.0 for GRID).

    Raises
    ------
    MiketalkError
        If the file is missing, ffmpeg cannot decode it, it has no video
        stream, no frame decodes, or its frame rate is unknown.
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"video file not found: {path}")
    args = _video_args(path, "verbose", start, frames)
    proc = subprocess.run(args, capture_output=True, check=False)
    log = proc.stderr.decode("utf-8", "replace")
    if proc.returncode != 0:
        if "matches no streams" in log:
            raise MiketalkError(f"{path} has no video stream")
        raise MiketalkError(f"ffmpeg could not decode {path}: {_tail(log)}")
    size = _SIZE_RE.search(log)
    rate = _RATE_RE.search(log)
    if size is None or not proc.stdout:
        raise MiketalkError(f"no video frame decoded from {path}: {_tail(log)}")
    width, height = int(size[1]), int(size[2])
    if rate is None or int(rate[1]) == 0 or int(rate[2]) == 0:
        raise MiketalkError(f"{path}: the video stream does not state its frame rate")
    frame_bytes = width * height * 3
    if len(proc.stdout) % frame_bytes:
        raise MiketalkError(
            f"{path}: ffmpeg's output ({len(proc.stdout)} bytes) is not a whole number of "
            f"{width}x{height} RGB frames"
        )
    frames = np.frombuffer(proc.stdout, np.uint8).reshape(-1, height, width, 3).copy()
    return frames, float(Fraction(int(rate[1]), int(rate[2])))


def _video_args(path: Path, loglevel: str, start: float | None, frames: int | None) -> list[str]:
    """ffmpeg's arguments decoding ``path``'s first video stream to raw RGB on its stdout."""
    import imageio_ffmpeg

    return [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-hide_banner",
        "-nostdin",
        "-loglevel",
        loglevel,
        "-threads",
        "1",
        *(["-ss", f"{start:.6f}"] if start else []),
        "-i",
        str(path),
        *(["-frames:v", str(int(frames))] if frames is not None else []),
        "-map",
        "0:v:0",
        "-an",
        "-sn",
        "-dn",
        "-fps_mode",
        "passthrough",
        "-filter_threads",
        "1",
        "-sws_flags",
        "bicubic+accurate_rnd+full_chroma_int",
        "-threads",
        "1",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "rgb24",
        "pipe:1",
    ]


def video_info(path: str | os.PathLike[str]) -> tuple[int, int, float]:
    """The width, height and frame rate of the first video stream of ``path``.

    Found by decoding its first frame as :func:`read_video` does (so the size is the one
    :func:`iter_video_frames` yields).

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
    first, fps = read_video(path, frames=1)
    return int(first.shape[2]), int(first.shape[1]), fps


def iter_video_frames(
    path: str | os.PathLike[str], *, start: float | None = None, frames: int | None = None
) -> Iterator[np.ndarray]:
    """Decode the first video stream of ``path`` one frame at a time, as a stream.

    The same frames as :func:`read_video` (the same ffmpeg arguments, so the same
    bytes), but memory holds one frame, not the whole video: a long HD video is
    read in constant memory. ffmpeg runs while the frames are consumed; closing the
    generator early (``break``, ``close()``) stops it.

    Parameters
    ----------
    path : str or os.PathLike
        Any video file ffmpeg reads.
    start : float, optional
        Seconds from the beginning (ffmpeg's accurate input seek), as :func:`read_video`.
    frames : int, optional
        Yield at most this many frames.

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
    width, height, _ = video_info(path)
    frame_bytes = width * height * 3
    args = _video_args(path, "error", start, frames)
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log)
        assert proc.stdout is not None
        finished = False
        try:
            while True:
                data = proc.stdout.read(frame_bytes)
                if not data:
                    break
                if len(data) < frame_bytes:
                    raise MiketalkError(
                        f"{path}: the video stream ended inside a {width}x{height} frame"
                    )
                yield np.frombuffer(data, np.uint8).reshape(height, width, 3).copy()
            finished = True
        finally:
            if not finished:
                proc.kill()
            proc.stdout.close()
            code = proc.wait()
        if code != 0:
            log.seek(0)
            text = log.read().decode("utf-8", "replace")
            raise MiketalkError(f"ffmpeg could not decode {path}: {_tail(text)}")


def _tail(log: str) -> str:
    """The last lines of ffmpeg's log worth quoting, joined into one line."""
    lines = [ln.strip() for ln in log.splitlines() if ln.strip()]
    keep = [ln for ln in lines if not ln.startswith("[") or "rror" in ln] or lines
    return " | ".join(keep[-_STDERR_TAIL:])


def read_media_audio(
    path: str | Path,
    *,
    rate: int = 16000,
    start: float | None = None,
    duration: float | None = None,
) -> np.ndarray:
    """Decode the first audio stream of a media file to mono int16 at ``rate`` Hz.

    Channels are averaged; ffmpeg resamples. ``start`` and ``duration`` (seconds)
    decode a part only.

    Parameters
    ----------
    path : str or Path
        Any file ffmpeg reads (``.mpg``, ``.mp4``, ``.wav``, ...).
    rate : int
        Sample rate of the result in Hz.

    Returns
    -------
    numpy.ndarray
        int16 samples, shape ``(n,)``.

    Raises
    ------
    MiketalkError
        If the file is missing, has no audio stream, or ffmpeg cannot decode it;
        the message names the file.
    """
    import imageio_ffmpeg

    path = Path(path)
    if isinstance(rate, bool) or not isinstance(rate, int) or not 1000 <= rate <= 384000:
        raise MiketalkError(f"rate must be a whole number of Hz in 1000..384000, got {rate!r}")
    if not path.is_file():
        raise MiketalkError(f"cannot read audio from {path}: no such file")
    command = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-nostdin", "-hide_banner", "-loglevel", "error",
        *(["-ss", f"{start:.6f}"] if start else []),
        "-i", str(path.resolve()),
        *(["-t", f"{duration:.6f}"] if duration is not None else []),
        "-map", "0:a:0", "-vn", "-sn", "-dn",
        "-ac", "1", "-ar", str(rate), "-acodec", "pcm_s16le", "-f", "s16le",
        "pipe:1",
    ]  # fmt: skip
    try:
        proc = subprocess.run(command, capture_output=True, timeout=_TIMEOUT, check=False)
    except subprocess.TimeoutExpired:
        raise MiketalkError(f"ffmpeg took longer than {_TIMEOUT:.0f} s to decode {path}") from None
    errors = proc.stderr.decode(errors="replace").strip()
    if proc.returncode != 0:
        if "matches no streams" in errors:
            raise MiketalkError(f"{path} has no audio stream")
        tail = errors.splitlines()[-1] if errors else f"exit status {proc.returncode}"
        raise MiketalkError(f"ffmpeg cannot decode the audio of {path}: {tail}")
    if len(proc.stdout) < 2:
        raise MiketalkError(f"{path} has an empty audio stream")
    return np.frombuffer(proc.stdout[: len(proc.stdout) // 2 * 2], dtype="<i2").astype(np.int16)
