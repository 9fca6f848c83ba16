"""What a player plays of a media file: its streams' durations, by decoding it."""

from __future__ import annotations

import os
import subprocess
from fractions import Fraction
from pathlib import Path

from miketalk.errors import MiketalkError
from miketalk.media.x264 import ffmpeg_exe

__all__ = ["probe_durations"]

_STDERR_TAIL = 15  # lines of ffmpeg's log quoted in errors


def probe_durations(path: str | os.PathLike[str]) -> tuple[float, float]:
    """Durations in seconds of the video and audio streams of a media file, by decoding it.

    Each stream's duration is ``end - start`` of its decoded frames (the last
    frame's timestamp plus its duration, minus the first timestamp), after the
    container's edit lists are applied, i.e. what a player plays.

    Parameters
    ----------
    path : path-like
        An mp4 (or any file ffmpeg reads).

    Returns
    -------
    video_seconds, audio_seconds : float
        0.0 for a stream the file does not have.

    Raises
    ------
    MiketalkError
        If the file is missing or ffmpeg cannot decode it.
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"media file not found: {path}")
    args = ["-hide_banner", "-nostdin", "-loglevel", "error", "-i", str(path), "-f", "framemd5"]
    proc = subprocess.run(
        [ffmpeg_exe(), *args, "-"],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        raise MiketalkError(f"ffmpeg could not read {path}:\n{_tail(proc.stderr)}")
    return _durations_from_framemd5(proc.stdout)


def _durations_from_framemd5(text: str) -> tuple[float, float]:
    """(video, audio) seconds from ffmpeg's framemd5 listing of the decoded frames."""
    media: dict[str, str] = {}
    time_base: dict[str, Fraction] = {}
    spans: dict[str, tuple[int, int]] = {}
    for line in text.splitlines():
        if line.startswith("#media_type") or line.startswith("#tb"):
            key, value = line[1:].split(":", 1)
            kind, stream = key.split()
            if kind == "tb":
                time_base[stream] = Fraction(value.strip())
            else:
                media[stream] = value.strip()
        elif line and not line.startswith("#"):
            stream, _dts, pts, duration = (f.strip() for f in line.split(",")[:4])
            start, end = int(pts), int(pts) + int(duration)
            old = spans.get(stream, (start, end))
            spans[stream] = (min(old[0], start), max(old[1], end))
    seconds = {"video": 0.0, "audio": 0.0}
    for stream, (start, end) in spans.items():
        kind = media.get(stream)
        if kind in seconds and seconds[kind] == 0.0:  # first stream of each kind
            seconds[kind] = float((end - start) * time_base[stream])
    return seconds["video"], seconds["audio"]


def _tail(text: str) -> str:
    lines = text.strip().splitlines()[-_STDERR_TAIL:]
    return "\n".join(lines) if lines else "(ffmpeg printed nothing)"
