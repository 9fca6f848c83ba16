"""Checks that a video given to ``dub`` or ``--background VIDEO`` can carry the model's mouth.

Registration (:func:`miketalk.composite.background.background_from_video`) already refuses a
video whose face does not register to the model's reference (nobody, a face turned away,
the person mirrored). Two things it cannot see:

* **a second face** (:func:`face_matches`): the reference's face is looked for over the
  whole first frame, at the scale its registration found; a second place that matches
  as well as :data:`SECOND_FACE` means the frame shows the face twice (two copies of
  the person side by side). A second face of *another* person matches the reference less
  and may pass: then the mouth goes on the face that registers, and the other keeps its own.
  Only for a model in the video's own pixels: a face crop (:mod:`miketalk.track`) shows
  one face, the tracker's detector having counted them in the whole frame, and there the
  face's own shifted copy matches the reference at up to 0.62 (the weekly addresses).
* **a colour the model's mouth cannot match** (:func:`colour_shift`): registration works
  on grey levels, so a video with its colour channels swapped registers as well as the
  original; the mouth's colour offset is then far from anything the model's renders
  show. The face's mean chromaticity after registration against the reference's:
  above :data:`MAX_COLOUR_SHIFT` the video is refused. A tint short of that passes: the
  mouth's colour is matched to the frame's.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["MAX_COLOUR_SHIFT", "SECOND_FACE", "colour_shift", "face_matches"]

#: Normalized cross-correlation at which a second place in the first frame counts as
#: another copy of the face: s1's 8 held-out clips' second best place scores 0.35 to 0.40,
#: two copies of his face side by side 0.89, a copy of his face's left 110 pixels pasted
#: beside him 0.70.
SECOND_FACE = 0.6

#: Largest distance of the registered face's mean chromaticity ``(r, g) / (r + g + b)``
#: from the reference's: s1's 8 held-out clips 0.004 to 0.011, a clip tinted (red x0.8,
#: blue x1.15; the composited mouth's colour then still matches) 0.072, its red and blue
#: channels swapped (the mouth shows orange on a blue face) 0.211.
MAX_COLOUR_SHIFT = 0.1


def face_matches(frame: np.ndarray, stabilizer, transform: np.ndarray) -> list[float]:
    """How well the reference's face matches each place of ``frame``, best first.

    Parameters
    ----------
    frame : numpy.ndarray
        (H, W, 3) uint8, a frame at the reference's size.
    stabilizer : miketalk.stabilize.Stabilizer
        The model's (its reference and registration mask).
    transform : numpy.ndarray
        (2, 3) the frame's registration: its scale sizes the template.

    Returns
    -------
    list of float
        The normalized cross-correlation (``TM_CCOEFF_NORMED``) of each separate peak
        (non-maximum suppression over a face's width), at most three, best first.
    """
    x, y, w, h = cv2.boundingRect(stabilizer.mask.astype(np.uint8))
    grey = cv2.cvtColor(np.ascontiguousarray(stabilizer.reference), cv2.COLOR_RGB2GRAY)
    template = grey[y : y + h, x : x + w]
    scale = float(np.sqrt(abs(np.linalg.det(np.asarray(transform)[:, :2]))))
    if abs(scale - 1) > 0.02:
        template = cv2.resize(template, (max(8, round(w * scale)), max(8, round(h * scale))))
    image = cv2.cvtColor(np.ascontiguousarray(frame), cv2.COLOR_RGB2GRAY)
    th, tw = template.shape
    if th > image.shape[0] or tw > image.shape[1]:
        return []
    score = cv2.matchTemplate(image, template, cv2.TM_CCOEFF_NORMED)
    peaks = []
    for _ in range(3):
        _, best, _, (px, py) = cv2.minMaxLoc(score)
        if best <= 0:
            break
        peaks.append(float(best))
        score[max(0, py - th // 2) : py + th // 2 + 1, max(0, px - tw // 2) : px + tw // 2 + 1] = -1
    return peaks


def colour_shift(steady: np.ndarray, reference: np.ndarray, face: np.ndarray) -> float:
    """Distance of the mean chromaticity of ``steady`` from ``reference``'s over ``face``.

    Parameters
    ----------
    steady, reference : numpy.ndarray
        (H, W, 3) uint8 RGB: the video's frames registered onto the reference (their
        median) and the reference.
    face : numpy.ndarray
        (H, W) bool: where to compare (the registration mask: the face outside the mouth).
    """

    def chroma(image: np.ndarray) -> np.ndarray:
        rgb = image[face].astype(np.float64).mean(axis=0)
        return rgb[:2] / max(float(rgb.sum()), 1e-9)

    return float(np.linalg.norm(chroma(steady) - chroma(reference)))
