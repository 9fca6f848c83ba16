"""A video's face tracked in two halves at once: this process tracks the first half while a
forked child tracks the second (:class:`~miketalk.workers.InChild`), on the other core.

The tracker (:class:`~miketalk.track.track.FaceTracker`) carries each frame's transform to
the next, so the second half starts as the tracker starts after a cut: the face detected
afresh in its first frame. The two records are then joined as one run would have made them
(:func:`joined`): the second half's first frame continues the first half's segment unless
one run would have started a new one there (the frame before it left out, a shot change by
the thumbnails, or a jump of the face points), and the whole is smoothed once, across the
join. The second half's first frames' raw transforms come from a fresh detection rather than
from the frame before: on the 10-s 720p dub of the weekly addresses the mouth is placed
within a fraction of a pixel of one run's (``docs/results.md``).

The child decodes the video from its start and drops the first half's frames (an exact frame
count, where a seek might land a frame off); the halves are split by the frames the container
states, and a video shorter than :data:`SHORTEST` frames is tracked in one run.
"""

from __future__ import annotations

import os

import numpy as np

from miketalk.track.result import Track
from miketalk.track.track import FaceTracker, TrackerSettings, _step, track_frames

__all__ = ["SHORTEST", "joined", "track_in_halves"]

#: Frames under which a video is tracked in one run (the child's start-up is not worth it).
SHORTEST = 120

_RECORDS = ("raw", "landmarks", "fit_error", "face_score", "reasons", "starts")


def track_in_halves(
    path: str | os.PathLike[str],
    *,
    fps: float,
    settings: TrackerSettings | None = None,
    start: float | None = None,
    frames: int | None = None,
) -> Track:
    """The face tracked through ``frames`` of ``path`` from ``start`` (all by default), the
    second half in a child process (see the module docstring).

    Parameters are :func:`~miketalk.track.track.track_video`'s, ``fps`` the video's rate.

    Returns
    -------
    Track
        As one run's, but for the second half's first frames.
    """
    from miketalk.media.decode import iter_video_frames, stated_seconds
    from miketalk.workers import InChild

    total = frames
    if total is None:
        seconds = stated_seconds(path)
        total = None if not seconds else int((seconds - (start or 0.0)) * fps)
    grey = {"start": start, "grey": True}
    if total is None or total < SHORTEST or not hasattr(os, "fork"):
        return track_frames(iter_video_frames(path, frames=frames, **grey), fps=fps,
                            settings=settings)  # fmt: skip
    half = total // 2
    with InChild(_second_half, path, fps, settings, half, frames, grey) as later:
        first = FaceTracker(fps=fps, settings=settings)
        for frame in iter_video_frames(path, frames=half, **grey):
            first.update(frame)
        second, thumbnail = later.result()
    return joined(first, second, thumbnail)


def _second_half(
    path, fps: float, settings, half: int, frames: int | None, grey: dict
) -> tuple[FaceTracker, np.ndarray | None]:
    """The child's work: frames ``half`` on tracked, and the first one's thumbnail."""
    from miketalk.media.decode import iter_video_frames

    tracker, thumbnail = FaceTracker(fps=fps, settings=settings), None
    for k, frame in enumerate(iter_video_frames(path, frames=frames, **grey)):
        if k < half:
            continue
        tracker.update(frame)
        if thumbnail is None:
            thumbnail = tracker._state.thumbnail
    return tracker, thumbnail


def joined(first: FaceTracker, second: FaceTracker, thumbnail: np.ndarray | None) -> Track:
    """The records of two trackers of consecutive frames joined and smoothed as one run's
    (``thumbnail``: the second's first frame's shot-change thumbnail).

    Raises
    ------
    MiketalkError
        When no frame was tracked, or the halves' frames differ in size.
    """
    from miketalk.errors import MiketalkError

    a, b = first._state, second._state
    if not b.reasons:
        return first.finish()
    if first._size is not None and second._size != first._size:
        raise MiketalkError(f"the halves' frames are {first._size} and {second._size}")
    if b.reasons[0] is None and a.reasons and a.reasons[-1] is None:
        s = first.settings
        cut = a.thumbnail is None or thumbnail is None or float(
            np.abs(thumbnail - a.thumbnail).mean()
        ) > s.cut_threshold  # fmt: skip
        if not cut and _step(a.raw[-1], b.raw[0]) <= s.max_step:
            b.starts[0] = False  # one run goes on in the same segment
    for name in _RECORDS:
        getattr(a, name).extend(getattr(b, name))
    first._size = first._size or second._size
    return first.finish()
