"""A first look at a few frames spread over a video: is a frontal face there at all?

Tracking a face through a video (:mod:`miketalk.track.track`) looks at every frame, and
at a frame without a face it runs the detector at two scales: a 13 s 720p video that shows
no frontal face anywhere (a profile, the picture turned on its side) cost ``dub`` 37 s
before it said so, where ``build`` refuses after looking at 7 frames
(:func:`miketalk.stabilize.faces.check_one_face`). :func:`first_look` runs the tracker's own
cold detection (:data:`~miketalk.track.track.TrackerSettings.detect_height`, then twice
it) on :data:`~miketalk.stabilize.faces.SAMPLES` frames spread over the video and refuses,
with ``build``'s line, only when none of them shows a face: a video that shows the face in
some frames is tracked as before, its frames without one named then.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.track.track import TrackerSettings

__all__ = ["first_look"]


def first_look(
    path: str | os.PathLike[str],
    *,
    source: str | None = None,
    tracker: TrackerSettings | None = None,
) -> None:
    """Refuse a video none of whose frames spread over it shows a frontal face.

    Parameters
    ----------
    path : str or os.PathLike
        The video.
    source : str, optional
        What the error calls it (its path by default).
    tracker : TrackerSettings, optional
        The tracker's settings (the detector's scales).

    Raises
    ------
    MiketalkError
        One line, as ``build``'s (:func:`~miketalk.stabilize.faces.no_face_line`), when no
        frame looked at shows a face; also a video that cannot be read (as
        :func:`~miketalk.media.decode.read_video` says).
    """
    from miketalk.media.decode import read_video, stated_seconds
    from miketalk.stabilize.faces import SAMPLES, no_face_line
    from miketalk.track.detect import detect_faces

    settings = tracker or TrackerSettings()
    duration = stated_seconds(path)
    if not duration or duration <= 0:
        return  # the container does not say how long it is: the tracking will tell
    looked = 0
    for t in (np.arange(SAMPLES) + 0.5) * duration / SAMPLES:
        try:
            frames, _ = read_video(path, start=float(t), frames=1)
        except MiketalkError:  # a stated length longer than the stream: look no further
            break
        grey = cv2.cvtColor(frames[0], cv2.COLOR_RGB2GRAY)
        height = grey.shape[0]
        looked += 1
        for scale in (settings.detect_height / height, 2 * settings.detect_height / height):
            if detect_faces(grey, scale=scale):
                return
            if scale >= 1.0:
                break
    if looked:
        raise MiketalkError(no_face_line(source or str(Path(path)), looked, looked))
