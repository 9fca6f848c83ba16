"""The mouth region: where the lips move, for computing metrics over the mouth."""

from __future__ import annotations

import cv2
import numpy as np

from synth_face.camera import Camera
from synth_face.face import Face

#: Lip vertices: skin vertices with elliptic coordinate mu below this (vermilion + margin).
LIP_MU = 0.45
#: Dilation of the hull, as a fraction of the image size.
DILATE_FRACTION = 0.03


def mouth_mask(face: Face, camera: Camera) -> np.ndarray:
    """Convex hull of the projected lips over every corpus target, dilated.

    Parameters
    ----------
    face : Face
        The face (its targets and lip vertices).
    camera : Camera
        The camera, which sets the image size.

    Returns
    -------
    ndarray, shape (size, size) bool
        True over the lips and their surroundings, whatever the pose.
    """
    skin = face.vertex_slices["skin"]
    lips = np.flatnonzero(face.parts[0].attrs["mu"] <= LIP_MU) + skin.start
    pts = np.concatenate(
        [camera.project(face.vertices(face.target(k))[lips])[:, :2] for k in face.target_keys]
    )
    hull = cv2.convexHull(np.rint(pts * 16.0).astype(np.int32))
    n = camera.size
    mask = np.zeros((n, n), dtype=np.uint8)
    cv2.fillConvexPoly(mask, hull, 1, lineType=cv2.LINE_8, shift=4)
    r = max(1, round(DILATE_FRACTION * n))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(mask, kernel).astype(bool)
