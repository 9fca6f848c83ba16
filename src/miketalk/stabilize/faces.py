"""How many faces a video shows: one person talking, or a mistake (none, several).

A face is built from one person's frontal face. :func:`check_one_face` counts
faces with dlib's frontal face detector (HOG, shipped inside dlib: no model
file) in a few frames spread over the video, and refuses a video where most of
them show no face, or several. dlib is a dependency of miketalk (face tracking,
:mod:`miketalk.track`); where it cannot be imported the check is skipped with a warning,
and the stabilizer's own rules (:mod:`miketalk.stabilize.locate`) are the only ones.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from miketalk.errors import MiketalkError

log = logging.getLogger(__name__)

#: Frames looked at, spread evenly over the video.
SAMPLES = 7


def check_one_face(frames: Sequence[np.ndarray], *, source: str) -> None:
    """Refuse frames of which most show no face or several (dlib's frontal faces, each frame
    upsampled once).

    Raises
    ------
    MiketalkError
        One line naming ``source``: no face in most frames, or several.
    """
    detector = _detector()
    if detector is None:
        log.warning("dlib is not installed: %s is not checked for one face", source)
        return
    counts = [len(detector(np.ascontiguousarray(f), 1)) for f in frames]
    majority = len(counts) // 2 + 1
    if sum(c == 0 for c in counts) >= majority:
        raise MiketalkError(no_face_line(source, sum(c == 0 for c in counts), len(counts)))
    if sum(c > 1 for c in counts) >= majority:
        raise MiketalkError(
            f"several faces in {source} (up to {max(counts)} in one frame): it needs one "
            "person's face alone in the picture; crop the video to that person"
        )


def no_face_line(source: str, none: int, looked: int) -> str:
    """The line that refuses a video without a face: ``none`` of the ``looked`` frames
    show one."""
    return (f"no face found in {source} ({none} of {looked} frames looked at show none): it "
            "needs one person's frontal face")  # fmt: skip


def _detector():
    try:
        import dlib  # noqa: F401
    except ImportError:
        return None
    from miketalk.stabilize.kept_detector import frontal_face_detector

    return frontal_face_detector()
