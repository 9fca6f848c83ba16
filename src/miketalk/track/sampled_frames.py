"""A few frames of a video at given times, in one decoding pass where that decodes less than
seeking to each.

The identity check (:func:`~miketalk.track.identity.person_distance`) looks at
:data:`~miketalk.stabilize.faces.SAMPLES` frames spread over a video, each the first frame
shown at or after its time (:func:`~miketalk.media.decode.read_video`'s accurate seek). A
seek decodes from the keyframe before its time; in a video with one keyframe (x264's
default keyframe interval is 250 frames, longer than a 10-s clip) the seven seeks decode the
video 3.5 times over, 1.33 s of ffmpeg's CPU on a 10-s 720p clip. :func:`sampled_frames`
lists the video's packets first (their timestamps and keyframe flags, copied, nothing
decoded), counts the frames each way decodes, and when one pass decodes fewer it decodes the
video once with ffmpeg's ``select`` filter keeping the same frames (the first shown at or
after each time, by the same timestamps) and converts only those to RGB, with
:func:`~miketalk.media.decode.read_video`'s own conversion: the same bytes. A video whose
frames do not follow its stated rate (read at a constant rate by their timestamps), or whose
packets cannot be listed, is read by seeks as before.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["PASS", "SEEKS", "decoded_frames", "sampled_frames"]

log = logging.getLogger(__name__)

#: The two ways, by name.
PASS, SEEKS = "pass", "seeks"

_PACKET_RE = re.compile(r"^stream #(\d+):\s*\n\s*keyframe=(\d)\s*\n.*?pts=(-?[\d.]+)", re.M | re.S)


def _packets(video: Path) -> list[tuple[float, bool]] | None:
    """The video stream's packets as ``(seconds, keyframe)``, sorted by time, from the
    start of the file's timeline (None: they cannot be listed)."""
    import imageio_ffmpeg

    from miketalk.console import child_process

    args = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-dump", "-i", str(video),
        "-map", "0:v:0", "-c", "copy", "-f", "null", "-",
    ]  # fmt: skip
    with child_process(args) as proc:
        _, err = proc.communicate()
    if proc.returncode != 0:
        return None
    text = err.decode("utf-8", "replace")
    index = re.search(r"Stream #0:(\d+)[^:]*: Video:", text)
    if index is None:
        return None
    start = re.search(r"Duration: [^\n]*?start: (-?[\d.]+)", text)
    zero = float(start[1]) if start else 0.0  # the timeline's zero, as a seek counts from
    found = [
        (float(m[3]) - zero, m[2] == "1")
        for m in _PACKET_RE.finditer(text)
        if int(m[1]) == int(index[1])
    ]
    found.sort()
    return found or None


def decoded_frames(
    packets: Sequence[tuple[float, bool]], times: Sequence[float], fps: float
) -> dict[str, int] | None:
    """The frames each way decodes to reach ``times`` (None: the packets' timestamps do not
    follow ``fps``, or times less than a frame and a half apart: read by seeks).

    Parameters
    ----------
    packets : sequence of (float, bool)
        Each frame's time (seconds on the timeline a seek counts on) and whether it is a
        keyframe, sorted.
    times : sequence of float
        The times looked at, increasing.
    fps : float
        The stated frame rate.
    """
    shown = np.array([t for t, _ in packets])
    if len(shown) < 2 or not np.all(np.abs(np.diff(shown) * fps - 1) < 0.5):
        return None
    if len(times) > 1 and np.min(np.diff(times)) * fps < 1.5:  # one frame for two times
        return None
    keys = np.flatnonzero([k for _, k in packets])
    wanted = np.searchsorted(shown, np.asarray(times, np.float64) - 1e-9)
    wanted = wanted[wanted < len(shown)]
    if len(wanted) == 0 or np.any(np.diff(wanted) <= 0) or len(keys) == 0:
        return None
    seeks = 0
    for i in wanted:
        before = keys[keys <= i]
        seeks += int(i - (before[-1] if len(before) else 0)) + 1
    return {PASS: int(wanted[-1]) + 1, SEEKS: seeks}


def sampled_frames(
    video: str | os.PathLike[str], times: Sequence[float], *, how: str = "auto"
) -> list[np.ndarray]:
    """The first frame shown at or after each of ``times`` (seconds, increasing), as
    :func:`~miketalk.media.decode.read_video` ``(start=t, frames=1)`` gives it; the frames
    of the times before the first one past the stream's end.

    Parameters
    ----------
    video : path
    times : sequence of float
    how : str
        ``auto`` (the way that decodes fewer frames, :func:`decoded_frames`), ``pass`` or
        ``seeks`` (a pass where it would not read the same frames is made by seeks).

    Returns
    -------
    list of numpy.ndarray
        ``(H, W, 3)`` uint8 RGB frames.
    """
    from miketalk.media.decode import read_video, video_info

    video = Path(video)
    if how != SEEKS:
        _, _, fps = video_info(video)
        packets = _packets(video)
        counts = None if packets is None else decoded_frames(packets, times, fps)
        if counts is not None and (how == PASS or counts[PASS] <= counts[SEEKS]):
            log.debug("%s: %d frames decoded in one pass, not %d", video, counts[PASS],
                      counts[SEEKS])  # fmt: skip
            return _one_pass(video, times)
    frames = []
    for t in times:
        try:
            got, _ = read_video(video, start=float(t), frames=1)
        except MiketalkError:  # a stated length longer than the stream
            break
        frames.append(got[0])
    return frames


def _one_pass(video: Path, times: Sequence[float]) -> list[np.ndarray]:
    """The frames of :func:`sampled_frames`, decoded once: ffmpeg's ``select`` keeps each
    time's first frame, by the timeline the accurate seek compares with."""
    import imageio_ffmpeg

    from miketalk.console import child_process
    from miketalk.media.decode import COLOUR_CONVERSIONS, video_info

    width, height, _ = video_info(video)
    chosen = "+".join(
        f"gte(t\\,{t:.6f})*(isnan(prev_t)+lt(prev_t\\,{t:.6f}))" for t in map(float, times)
    )
    args = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-loglevel", "error",
        "-threads", "1", "-i", str(video), "-frames:v", str(len(times)),
        "-map", "0:v:0", "-an", "-sn", "-dn", "-vf", f"select={chosen}",
        "-fps_mode", "passthrough", "-filter_threads", "1",
        "-sws_flags", COLOUR_CONVERSIONS["accurate"], "-threads", "1",
        "-f", "rawvideo", "-pix_fmt", "rgb24", "pipe:1",
    ]  # fmt: skip
    with child_process(args) as proc:
        out, err = proc.communicate()
    if proc.returncode != 0:
        from miketalk.media.ffmpeg_log import unreadable

        raise unreadable(video, err.decode("utf-8", "replace"))
    size = width * height * 3
    return [
        np.frombuffer(out, np.uint8, size, i * size).reshape(height, width, 3).copy()
        for i in range(len(out) // size)
    ]
