"""What ffmpeg's log says of a video it read: the decoded stream's rate, size and pixel
format, the file's stated duration, and, when it failed, why in plain words.

ffmpeg's own words (``[in#0 @ 0x55...] Error opening input: Invalid data found when
processing input | ... | Exiting with exit code -1094995529``) name no cause a user can
act on; :func:`unreadable` says what is true of the file, and logs ffmpeg's words at the
``INFO`` level (``-v`` shows them).
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from miketalk.errors import MachineFailure, MiketalkError

log = logging.getLogger(__name__)

#: Lines of ffmpeg's log quoted (under ``-v``).
STDERR_TAIL = 6
# the filter graph's input: "... w:360 h:288 pixfmt:yuv420p tb:1/90000 fr:25/1 sar:1/1 ..."
RATE_RE = re.compile(r"input from stream \S+ @ \S+\] .*?\bfr:(\d+)/(\d+)")
# the output stream: "Stream #0:0: Video: rawvideo ... rgb24(...), 360x288 [SAR ..."
SIZE_RE = re.compile(r"Output #0.*?Stream #0:0.*?Video: rawvideo\b.*?, (\d+)x(\d+)", re.DOTALL)
# the same line's decoded pixel format and range: "... pixfmt:yuv420p ... range:tv ..."
PIXFMT_RE = re.compile(r"input from stream \S+ @ \S+\] .*?\bpixfmt:(\w+)(?:.*?\brange:(\w+))?")
# the same line's colour space: "... csp:unknown range:unknown ..."
CSP_RE = re.compile(r"input from stream \S+ @ \S+\] .*?\bcsp:(\w+)")
# the input's summary: "  Duration: 00:00:03.00, start: 0.000000, bitrate: 152 kb/s"
DURATION_RE = re.compile(r"^\s*Duration: (\d+):(\d\d):(\d\d(?:\.\d+)?)", re.MULTILINE)
#: What ffmpeg says of a file it cannot open as media at all (its container unknown, or
#: the part that indexes it missing: a file cut short, or not a video).
_NOT_MEDIA = (
    "Invalid data found when processing input",
    "moov atom not found",
    "could not find codec parameters",
    "End of file",
)

#: 8-bit planar YUV formats whose luma plane is taken as it is for grey frames (the
#: first plane, ``extractplanes=y``), then mapped to full range by :data:`TV_TO_FULL`
#: where it is limited: the bytes of ffmpeg's own grey conversion (``-pix_fmt gray``,
#: accurate rounding), for a third of its cost at 1080p (1.1 ms a frame).
LUMA_PLANAR = frozenset(
    f"yuv{j}{s}p" for j in ("", "j") for s in ("420", "422", "444", "440", "411", "410")
)


#: Limited-range luma (16 to 235) to full range, rounded: swscale's grey conversion
#: exactly (no value of ``(y - 16) * 255 / 219`` is a tie).
TV_TO_FULL = np.clip(np.round((np.arange(256) - 16) * 255 / 219), 0, 255).astype(np.uint8)


class Logged(NamedTuple):
    """What a read's verbose log says of its file, kept per file by :mod:`miketalk.media.decode`."""

    #: How its grey frames are taken (:func:`luma_kind`).
    luma: str | None
    #: The seconds it states it lasts (:func:`stated_duration`).
    duration: float | None
    #: Whether its frames are decoded in the encoder's own colours (:func:`plain_i420`).
    i420: bool = False

    @classmethod
    def of(cls, log_text: str) -> Logged:
        """From ffmpeg's verbose log."""
        return cls(luma_kind(log_text), stated_duration(log_text), plain_i420(log_text))


def encoding_failure(folder: Path, log_text: str) -> MiketalkError:
    """What a failed encoding into ``folder`` is, in one line: the machine's (a full disk, a
    quota, an input/output error: :class:`MachineFailure`, exit status 1) when ffmpeg's log
    says so, else ffmpeg's last words joined (:func:`tail`)."""
    from miketalk.media.atomic import MACHINE_ERRNOS

    for number in sorted(MACHINE_ERRNOS):
        if os.strerror(number) in log_text:
            return MachineFailure(
                f"cannot write the video in {folder}: {os.strerror(number)} (ffmpeg stopped "
                "encoding it); nothing was written"
            )
    return MiketalkError(f"ffmpeg failed encoding the video: {tail(log_text)}")


def tail(text: str) -> str:
    """The last lines of ffmpeg's log worth quoting, joined into one line."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    keep = [ln for ln in lines if not ln.startswith("[") or "rror" in ln] or lines
    return " | ".join(keep[-STDERR_TAIL:])


def luma_kind(log_text: str) -> str | None:
    """From ffmpeg's verbose log, how grey frames are taken: ``tv`` (the luma plane, mapped
    from limited range), ``pc`` (as it is), None (ffmpeg converts them)."""
    found = PIXFMT_RE.search(log_text)
    if found is None or found[1] not in LUMA_PLANAR:
        return None
    full = found[1].startswith("yuvj") or found[2] == "pc"
    return "pc" if full else "tv"


#: Colour spaces whose RGB ffmpeg's conversion and OpenCV's (:mod:`miketalk.media.yuv`)
#: both take as BT.601: none stated, or BT.601's own names.
BT601 = frozenset({"unknown", "bt470bg", "smpte170m"})


def plain_i420(log_text: str) -> bool:
    """Whether ffmpeg's verbose log says the video's frames decode to 8-bit 4:2:0 in limited
    range and BT.601 (or no stated colour space): the planes the encoder reads
    (:mod:`miketalk.media.yuv`), whose RGB OpenCV's conversion gives as ffmpeg's does (but
    for rounding)."""
    found, space = PIXFMT_RE.search(log_text), CSP_RE.search(log_text)
    if found is None or found[1] != "yuv420p" or found[2] == "pc":
        return False
    return space is None or space[1] in BT601


def stated_duration(log_text: str) -> float | None:
    """The seconds the input states it lasts (its container's ``Duration``), or None."""
    found = DURATION_RE.search(log_text)
    if found is None:
        return None
    return int(found[1]) * 3600 + int(found[2]) * 60 + float(found[3])


def unreadable(path: Path, log_text: str, *, decoded: bool = True) -> MiketalkError:
    """The one-line error of a video ffmpeg failed on, in plain words (``decoded=False``:
    it ran to its end, but no frame came out); ffmpeg's own logged at ``INFO`` (``-v``)."""
    log.info("ffmpeg on %s: %s", path, tail(log_text))
    if not decoded:
        return MiketalkError(
            f"no video frame decoded from {path} (cut short, or no picture in it); -v shows "
            "ffmpeg's own words"
        )
    if any(words in log_text for words in _NOT_MEDIA):
        return MiketalkError(
            f"{path} is not a video ffmpeg can read (cut short, or another kind of file); "
            "-v shows ffmpeg's own words"
        )
    return MiketalkError(
        f"ffmpeg stopped reading {path}: the video is damaged or of a kind it cannot decode; "
        "-v shows ffmpeg's own words"
    )


#: Seconds by which a video's frames may end before the duration its file states (its
#: container's: the longer of its streams) before a whole read says it ends early.
EARLY_END = 0.25


def warn_if_early_end(path: Path, frames: int, fps: float, stated: float | None) -> bool:
    """Warn, and return True, when the ``frames`` of a whole video at ``fps`` end more
    than :data:`EARLY_END` seconds before the duration its file states (``stated``): a file
    cut short whose index survives (a ``+faststart`` mp4's first half), or sound that runs
    on after the picture. Only the frames there are are used (a dub loops them, as it
    does a video shorter than its speech), so the output is not wrong, but it is not the
    whole video the user meant."""
    if not stated or not fps or stated - frames / fps <= EARLY_END:
        return False
    log.warning(
        "%s ends early: its %d frames last %.2f s of the %.2f s the file states (cut short, "
        "or sound that runs on without picture); only those frames are used",
        path.name, frames, frames / fps, stated,
    )  # fmt: skip
    return True


__all__ = [
    "BT601",
    "EARLY_END",
    "LUMA_PLANAR",
    "RATE_RE",
    "SIZE_RE",
    "TV_TO_FULL",
    "Logged",
    "luma_kind",
    "plain_i420",
    "stated_duration",
    "tail",
    "unreadable",
    "warn_if_early_end",
]
