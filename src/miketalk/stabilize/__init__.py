"""Stabilize a talking head: register every frame to one reference frame, on the face.

Where things are (no learned landmark model; every rule is a property of a
frontal talking head in front of a plain background, not of one person):

- **head** (:func:`locate_head`): the frame's plain background is the
  low-gradient region connected to its top and side edges; the rest is the
  person. The head ends at the neck: going down the silhouette's row widths,
  after the first clear narrowing below the widest part of the head (the
  jaw), the narrowest row before the silhouette widens again (shoulders).
- **face** (:func:`locate_face`): the head's skin, by the person's own skin
  colour: a Lab colour model (trimmed mean and covariance) of the centre of
  the lower head (nose and cheeks are skin for anyone), every head pixel
  within ``tolerance`` Mahalanobis units of it, the connected region, closed
  by its convex hull (so eyes, nostrils and mouth are inside). Hair, a fringe
  over the forehead, the background and the neck below the jaw are out.
- **mouth** (:func:`locate_mouth`): the part of the lower face that changes
  most *most of the time*: per pixel the median over frames of
  ``|frame - temporal median|`` (a blink, a few frames, does not count),
  smoothed, searched in the lowest 35 % and the middle 60 % of the face, away
  from its outline; the box is the connected region above half the peak.
- **eyes and brows** (inside :func:`registration_mask`): a band 0.8 to 1.4
  mouth-box widths above the mouth box (a face's proportions).

What is registered on (:func:`registration_mask`, ``region``):

- ``"face"``: the face minus the mouth zone (the mouth box grown by
  ``margin`` face widths, and the chin below it, which moves with the jaw);
- ``"central"`` (the default): the rows from the brows to the mouth zone
  (brows, eyes, nose, cheeks): no forehead (across GRID's recording sessions
  the hair falls differently over it) and no jaw (it moves with speech);
- ``"rigid"``: the band between the eyes and the mouth zone (nose, cheeks):
  no eyes (blinks, gaze) either. Too small to register on alone (it does not
  fix rotation and scale well); it is where the residual motion is measured
  for the issue's target.

All three stay ``edge`` face widths inside the face's outline, where the
moving silhouette would otherwise meet the still background.

Registration (:class:`Stabilizer`; one frame in :mod:`~miketalk.stabilize.ecc`): an affine
transform per frame by ECC
(enhanced correlation coefficient, invariant to the gain and offset of the
brightness) with the mask on the reference (``cv2.findTransformECCWithMask``:
ECC with the mask on the *input* image, all older OpenCV offers, is biased by
0.3 to 0.5 px on a synthetic face moved by a known transform, 0.03 px with
the template mask), on a two-level pyramid (half size, then full size) of
crops around the mask; each frame starts from the previous frame's
transform, a clip's first frame (or one after a failure) from a translation
found by phase correlation. Then once more at full size without the pixels
that still differ by more than ``outlier_factor`` times their median (a
blink, a raised brow): on GRID this halves the 95th percentile of the
residual motion. Affine rather than Euclidean: the head's distance to the
camera changes (scale) and a nod foreshortens the face vertically only.

An affine transform does not bring another session's face onto the
reference: the head's pitch and yaw differ by a few degrees from session to
session and the face is not flat (the nose, the jaw line). So each clip also
gets one smooth *conform* field (:meth:`Stabilizer.conform`,
:mod:`~miketalk.stabilize.conform`): the dense flow
(DIS, preset medium) from the reference to the clip's median affinely
stabilized frame, fitted by a bivariate cubic polynomial over the face below
the brows outside the mouth zone (the cheeks on either side of the mouth, so
that the mouth's field is interpolated, not extrapolated) and faded out
beyond the face. One field per clip, not per frame, so the movements of
speech within the clip are left as they are.

Checks (a frame that will not register raises :class:`MiketalkError` naming
the clip and frame): ECC stops without converging (OpenCV raises), or the
final correlation coefficient over the mask is below ``min_correlation``
(0.8: on GRID's 200 clips every real frame scores 0.93 or more; the 48 that
fail, the corrupt first 12 frames of 4 clips, 0.64 or less). A clip whose
conform field exceeds ``max_conform`` widths of its mask does not show the
reference's face (raises as well).

Reference: one frame for all clips, since the head moves between clips as
well as within them. :func:`choose_reference` picks, among a clip's first
frames (GRID's clips open with silence: the mouth is closed), the one nearest
their median (no blink, no movement); the first training clip's is used.

Measurement: :func:`residual_motion`, the mean magnitude of the DIS optical
flow (preset medium) from the reference to each frame over a mask; see
:mod:`miketalk_lab.bench.stabilization` for the numbers.
"""

from miketalk.stabilize.locate import (
    Box,
    Region,
    choose_reference,
    locate_face,
    locate_head,
    locate_mouth,
    registration_mask,
)
from miketalk.stabilize.measure import residual_motion
from miketalk.stabilize.stabilizer import Stabilized, Stabilizer
from miketalk.stabilize.warp import warp_to_reference

__all__ = [
    "Box",
    "Region",
    "Stabilized",
    "Stabilizer",
    "choose_reference",
    "locate_face",
    "locate_head",
    "locate_mouth",
    "registration_mask",
    "residual_motion",
    "warp_to_reference",
]
