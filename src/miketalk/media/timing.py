"""When a video's frames are shown: its frames' timestamps, and a refusal of a variable rate.

A video is decoded as a list of frames and one frame rate (the rate its stream states). A
variable-frame-rate video (a phone's recording, a screen capture) has frames whose
timestamps are not ``i / fps``: played at the stated rate, its frames would come too early
or too late, and the new speech would drift from the mouth. :func:`frame_times` reads the
timestamps of the video's packets (no decoding: ffmpeg copies them), and
:func:`check_constant_rate` refuses, in one line, a video whose frames do not play at its
stated rate.
"""

from __future__ import annotations

import logging
import os
import subprocess
from collections.abc import Callable
from fractions import Fraction
from itertools import pairwise
from pathlib import Path

from miketalk.errors import MiketalkError

log = logging.getLogger("miketalk.media.decode")  # its warnings, as before

__all__ = ["check_constant_rate", "frame_times", "framemd5_packets", "packet_span", "resample_rate"]

#: How far (seconds, and as a share of the video's length) the frames' timestamps may
#: end from where the stated rate puts them.
TOLERANCE_SECONDS, TOLERANCE_SHARE = 1.5, 0.02


def framemd5_packets(text: str) -> tuple[Fraction, list[tuple[int, int]]]:
    """ffmpeg's ``framemd5`` listing of stream 0: its time base and each packet's
    ``(pts, duration)`` in that base, in the listing's order."""
    base, rows = Fraction(1), []
    for line in text.splitlines():
        if line.startswith("#tb 0:"):
            base = Fraction(line.split(":", 1)[1].strip())
        elif line and not line.startswith("#"):
            fields = [f.strip() for f in line.split(",")]
            if fields[0] == "0":
                rows.append((int(fields[2]), int(fields[3])))
    return base, rows


def frame_times(path: str | os.PathLike[str]) -> tuple[list[float], float]:
    """The presentation times (seconds, sorted, from 0) of a video's frames, and the last
    frame's duration.

    Raises
    ------
    MiketalkError
        If ffmpeg cannot read the video stream.
    """
    from miketalk.media.video import ffmpeg_exe

    proc = subprocess.run(
        [
            ffmpeg_exe(), "-hide_banner", "-nostdin", "-loglevel", "error", "-i", str(path),
            "-map", "0:v:0", "-c", "copy", "-f", "framemd5", "-",
        ],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if proc.returncode != 0:
        raise MiketalkError(f"ffmpeg could not read the frames of {path}")
    base, rows = framemd5_packets(proc.stdout)
    if not rows:
        raise MiketalkError(f"{path} has no video frames")
    rows.sort()
    first = rows[0][0]
    return [float((pts - first) * base) for pts, _ in rows], float(rows[-1][1] * base)


def check_constant_rate(path: str | os.PathLike[str], fps: float, n_frames: int) -> None:
    """Refuse a video whose frames' timestamps do not follow its stated rate ``fps``.

    The ``n_frames`` frames, shown at ``fps``, last ``n_frames / fps`` seconds; by their
    timestamps they last from the first to the end of the last. When the two differ by more
    than a frame and :data:`TOLERANCE_SHARE` of the length (or :data:`TOLERANCE_SECONDS`
    frames' worth), the video has a variable frame rate.

    Raises
    ------
    MiketalkError
        In one line, saying how long the video is by its timestamps and at its rate, and how
        to convert it.
    """
    times, last = frame_times(path)
    stated = n_frames / fps
    span = times[-1] + (last if last > 0 else 1.0 / fps)
    allowed = max(TOLERANCE_SECONDS / fps, TOLERANCE_SHARE * stated)
    if abs(span - stated) > allowed:
        raise MiketalkError(
            f"{Path(path).name} has a variable frame rate: its {n_frames} frames span "
            f"{span:.2f} s by their timestamps, but would play as {stated:.2f} s at its "
            f"{fps:g} fps; convert it to a constant rate first "
            f"(ffmpeg -i {Path(path).name} -vf fps={fps:g} constant.mp4)"
        )


#: ffmpeg's AV_NOPTS_VALUE: a packet without a timestamp.
NO_PTS = -(2**63)


def packet_span(path: Path, run: Callable) -> tuple[int, Fraction] | None:
    """The number of video packets of ``path`` and the seconds they span (the first's
    start to the last's end); None when they cannot tell (no timestamps, fewer than two
    packets, a stream ffmpeg cannot copy: the decode itself then says what is wrong).
    ``run(args)`` runs ffmpeg to its end: ``(exit status, stdout, stderr)``."""
    import imageio_ffmpeg

    code, out, _ = run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-loglevel", "error",
            "-i", str(path), "-map", "0:v:0", "-c", "copy", "-f", "framemd5", "pipe:1",
        ]
    )  # fmt: skip
    if code != 0:
        return None
    base, rows = framemd5_packets(out.decode("ascii", "replace"))
    if len(rows) < 2 or any(pts == NO_PTS for pts, _ in rows):
        return None
    rows.sort()
    gaps = sorted(b - a for (a, _), (b, _) in pairwise(rows))
    last = rows[-1][1] if rows[-1][1] > 0 else gaps[len(gaps) // 2]  # else a usual gap
    span = (rows[-1][0] + last - rows[0][0]) * base
    return (len(rows), span) if span > 0 else None


def resample_rate(
    path: Path, stated: Fraction | None, slack_frames: float, run: Callable
) -> Fraction | None:
    """The constant rate a video's frames are to be read at by their timestamps, or None:
    they follow its ``stated`` rate (they span frames / rate seconds within
    ``slack_frames``; :mod:`miketalk.media.decode`); warned about when not None. ``run``
    as :func:`packet_span`'s."""
    found = packet_span(path, run)
    if found is None:
        return None
    count, span = found
    slack = slack_frames / stated if stated else 0
    if stated is not None and abs(span - count / stated) <= slack:
        return None
    rate = (count / span).limit_denominator(1001)
    said = f"at its stated {float(stated):g} fps" if stated else "at no stated rate"
    log.warning(
        "%s has a variable frame rate (%d frames over %.2f s by their timestamps, %s): read "
        "at a constant %g fps, frames repeated or dropped by their timestamps",
        path.name, count, float(span), said, float(rate),
    )  # fmt: skip
    return rate
