"""ECC's refinement of a tracked face crop, kept only where it refines.

In the crop (:mod:`miketalk.track.crop`) the tracker's similarity already puts the face
within a fraction of a pixel of where it belongs (``docs/tracking.md``); ECC on the face
outside the mouth (:class:`~miketalk.stabilize.Stabilizer`) takes the last of it, and
an affine part the similarity has not. Across sessions, light and days it can also
converge on a wrong warp, or not converge. :func:`refined` keeps a registration that
moves no corner of the registered region by more than ``limit`` crop pixels, and gives
every other tracked frame the crop's own pixels (the identity): ECC refines the tracker,
it does not overrule it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["IDENTITY", "MAX_REFINEMENT", "refine_crops", "refined"]

#: The crop's own pixels.
IDENTITY = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
IDENTITY.setflags(write=False)

#: The most a refinement may move the registered region's corners, in eye distances
#: (the tracker's error is a few hundredths of one: 0.32 px RMS at 720p on hard s1).
MAX_REFINEMENT = 0.08


def refined(
    transforms: np.ndarray,
    tracked: np.ndarray,
    box: tuple[int, int, int, int],
    limit: float,
) -> tuple[np.ndarray, int]:
    """Registrations of tracked crops, each kept or replaced by the identity.

    Parameters
    ----------
    transforms : numpy.ndarray
        ``(N, 2, 3)`` ECC's registrations (reference crop to frame crop), NaN where it
        failed.
    tracked : numpy.ndarray
        ``(N,)`` bool: the frames whose face the tracker followed.
    box : tuple of int
        ``(x, y, w, h)`` the registered region in crop pixels (its corners are checked).
    limit : float
        The most a corner may move, crop pixels.

    Returns
    -------
    transforms : numpy.ndarray
        ``(N, 2, 3)``: kept, the identity, or NaN for a frame not tracked.
    replaced : int
        How many tracked frames took the identity.
    """
    out = np.array(transforms, dtype=np.float64, copy=True)
    tracked = np.asarray(tracked, bool)
    x, y, w, h = box
    corners = np.array([[x, y, 1.0], [x + w, y, 1.0], [x, y + h, 1.0], [x + w, y + h, 1.0]])
    with np.errstate(invalid="ignore"):
        moved = np.einsum("nij,kj->nki", out, corners) - corners[None, :, :2]
        far = np.linalg.norm(moved, axis=2).max(axis=1)
    bad = tracked & ~(far <= limit)  # NaN compares False: failed registrations too
    out[bad] = IDENTITY
    out[~tracked] = np.nan
    return out, int(bad.sum())


def refine_crops(transforms: np.ndarray, tracked: np.ndarray, stabilizer) -> tuple[np.ndarray, int]:
    """:func:`refined` over a stabilizer's registration mask (its bounding box), the limit
    :data:`MAX_REFINEMENT` of its mouth box's width (about an eye distance).

    Parameters
    ----------
    transforms, tracked : numpy.ndarray
        As :func:`refined`.
    stabilizer : miketalk.stabilize.Stabilizer
        The crop's (its ``mask`` and ``mouth_box``).
    """
    import cv2

    box = cv2.boundingRect(np.asarray(stabilizer.mask, np.uint8))
    return refined(transforms, tracked, box, MAX_REFINEMENT * stabilizer.mouth_box[2])
