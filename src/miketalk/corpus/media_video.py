"""Decode a video file to RGB frames with the ffmpeg binary bundled with imageio-ffmpeg.

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

Self-contained on purpose (only numpy, imageio-ffmpeg and
:class:`miketalk.errors.MiketalkError`), so it can move to a media package.
"""

from __future__ import annotations

import os
import re
import subprocess
from fractions import Fraction
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["read_video"]

_STDERR_TAIL = 6  # lines of ffmpeg's log quoted in an error
# the filter graph's input: "... w:360 h:288 pixfmt:yuv420p tb:1/90000 fr:25/1 sar:1/1 ..."
_RATE_RE = re.compile(r"input from stream \S+ @ \S+\] .*?\bfr:(\d+)/(\d+)")
# the output stream: "Stream #0:0: Video: rawvideo ... rgb24(...), 360x288 [SAR ..."
_SIZE_RE = re.compile(r"Output #0.*?Stream #0:0.*?Video: rawvideo\b.*?, (\d+)x(\d+)", re.DOTALL)


def read_video(path: str | os.PathLike[str]) -> tuple[np.ndarray, float]:
    """Decode every frame of the first video stream of ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Any video file ffmpeg reads (GRID's MPEG-1 ``.mpg``, mp4, ...). Audio
        streams are ignored.

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
    import imageio_ffmpeg

    args = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-hide_banner",
        "-nostdin",
        "-loglevel",
        "verbose",
        "-threads",
        "1",
        "-i",
        str(path),
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


def _tail(log: str) -> str:
    """The last lines of ffmpeg's log worth quoting, joined into one line."""
    lines = [ln.strip() for ln in log.splitlines() if ln.strip()]
    keep = [ln for ln in lines if not ln.startswith("[") or "rror" in ln] or lines
    return " | ".join(keep[-_STDERR_TAIL:])
