"""The canonical face frame: where the five landmarks of a frontal face lie, and its face box.

Coordinates ``(u, v)`` in the canonical frame: the origin midway between the
centres of the two eyes (each eye's centre the midpoint of its two corners), ``u``
along the line from the image-left eye to the image-right eye, ``v`` downwards, the
unit the distance between the eyes' centres (the *eye distance*). A frame's
transform to it (a similarity: scale, rotation, translation) is the least-squares
fit of the frame's five landmarks onto :data:`CANONICAL_LANDMARKS`
(:func:`~miketalk.track.similarity.fit_similarity`).

The five landmarks are those of dlib's 5-point shape predictor
(``shape_predictor_5_face_landmarks.dat``), in its order: the image-right eye's
outer and inner corners, the image-left eye's outer and inner corners, the bottom
of the nose (between the nostrils). Their canonical positions are the mean over 192
frontal faces of 18 videos (10 of GRID's talker s1, the 8 weekly-address clips of
``data/obama``), each normalized to the canonical frame, rounded and made
left-right symmetric: the corners at ``u = ±0.70, ±0.30`` (s1 and Obama both within
0.01), the nose at ``v = 0.77`` (0.84 for s1, 0.70 for Obama: the nose is the
person's own, and this point only sets where the face's centre lies in the crop).

:data:`CANONICAL_BOX` is where dlib's frontal face detector puts its box around
such a face (the mean over the same frames: centre ``(0.01, 0.54)``, sides 2.54),
used to give the shape predictor the box it was trained with.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CANONICAL_BOX", "CANONICAL_LANDMARKS", "LANDMARK_NAMES"]

#: The five landmarks in dlib's 5-point order, in canonical coordinates (eye distances).
CANONICAL_LANDMARKS = np.array(
    [[0.70, 0.0], [0.30, 0.0], [-0.70, 0.0], [-0.30, 0.0], [0.0, 0.77]], dtype=np.float64
)
CANONICAL_LANDMARKS.setflags(write=False)

#: Their names, in the same order (image-left/right, as the frame shows them).
LANDMARK_NAMES = (
    "right eye, outer corner",
    "right eye, inner corner",
    "left eye, outer corner",
    "left eye, inner corner",
    "nose",
)

#: The frontal face detector's box in canonical coordinates: (centre u, centre v, side).
CANONICAL_BOX = (0.0, 0.54, 2.54)
