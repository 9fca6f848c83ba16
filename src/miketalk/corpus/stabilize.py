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

Registration (:class:`Stabilizer`): an affine transform per frame by ECC
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
gets one smooth *conform* field (:meth:`Stabilizer.conform`): the dense flow
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
:mod:`miketalk.bench.stabilization` for the numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from miketalk.errors import MiketalkError

__all__ = [
    "Box",
    "Stabilized",
    "Stabilizer",
    "choose_reference",
    "locate_face",
    "locate_head",
    "locate_mouth",
    "registration_mask",
    "residual_motion",
]

Box = tuple[int, int, int, int]
Region = Literal["face", "central", "rigid"]
_LUMA = np.array([[0.299, 0.587, 0.114]], np.float32)  # BT.601, as cv2.COLOR_RGB2GRAY


# --- small helpers -------------------------------------------------------------------------


def _gray(frame: np.ndarray) -> np.ndarray:
    """A frame as (H, W) float32 luma."""
    frame = np.asarray(frame)
    if frame.ndim == 3:
        return cv2.transform(frame.astype(np.float32), _LUMA)
    return frame.astype(np.float32)


def _gray_stack(frames: np.ndarray) -> np.ndarray:
    """(N, H, W[, 3]) frames as (N, H, W) float32 luma, in one call."""
    frames = np.asarray(frames)
    if frames.ndim == 4:
        n, h, w, _ = frames.shape
        flat = np.ascontiguousarray(frames).reshape(n * h, w, 3).astype(np.float32)
        return cv2.transform(flat, _LUMA).reshape(n, h, w)
    return frames.astype(np.float32)


def _u8gray(frame: np.ndarray) -> np.ndarray:
    frame = np.asarray(frame)
    return cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY) if frame.ndim == 3 else frame


def _extent(mask: np.ndarray) -> Box:
    """Bounding box ``(x, y, w, h)`` of the true pixels of ``mask``."""
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        raise MiketalkError("the mask is empty")
    return int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1)


def _disk(size: float) -> np.ndarray:
    k = max(3, round(size) | 1)
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    """``mask`` with every region it encloses (not connected to the frame's border) added."""
    _, labels = cv2.connectedComponents((~mask).astype(np.uint8), connectivity=4)
    edge = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    return mask | ~np.isin(labels, edge[edge > 0])


def _largest(mask: np.ndarray) -> np.ndarray:
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n < 2:
        return np.zeros(mask.shape, bool)
    return labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))


def _check_frame(frame: np.ndarray, what: str) -> np.ndarray:
    frame = np.asarray(frame)
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
        raise MiketalkError(
            f"{what} needs an (H, W, 3) uint8 RGB frame, got shape {frame.shape} {frame.dtype}"
        )
    return frame


# --- where the head, the face and the mouth are ----------------------------------------------


def locate_head(
    frame: np.ndarray, *, smoothing: float = 1.5, flat_factor: float = 3.0
) -> np.ndarray:
    """The head above the neck: what is not plain background, cut at the neck.

    Parameters
    ----------
    frame : numpy.ndarray
        (H, W, 3) uint8 RGB, a head and shoulders in front of a plain
        (possibly graded) background that reaches the top and side edges.
    smoothing : float
        Gaussian sigma (pixels) before the colour gradient is taken.
    flat_factor : float
        A pixel is flat when its Lab gradient is below this many times the
        median gradient of a band just inside the top and side edges.

    Returns
    -------
    numpy.ndarray
        (H, W) bool.

    Raises
    ------
    MiketalkError
        If the frame is not RGB uint8, or the top and side edges are not
        plain (no background to tell the person from).
    """
    frame = _check_frame(frame, "locate_head")
    h, w = frame.shape[:2]
    lab = cv2.cvtColor(cv2.GaussianBlur(frame, (0, 0), smoothing), cv2.COLOR_RGB2LAB)
    lab = lab.astype(np.float32)
    gx = cv2.Sobel(lab, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(lab, cv2.CV_32F, 0, 1, ksize=3)
    grad = np.sqrt((gx * gx + gy * gy).sum(axis=2))
    inset = max(2, round(0.02 * min(h, w)))  # skips a dark first line or an edge artefact
    band = np.zeros((h, w), bool)
    band[inset : 2 * inset, inset:-inset] = True
    band[inset:-inset, inset : 2 * inset] = True
    band[inset:-inset, -2 * inset : -inset] = True
    flat = (grad < max(flat_factor * float(np.median(grad[band])), 1.0)).astype(np.uint8)
    _, labels = cv2.connectedComponents(flat, connectivity=4)
    seeds = np.unique(labels[band & (flat > 0)])
    background = np.isin(labels, seeds[seeds > 0])
    if background.mean() < 0.05:
        raise MiketalkError(
            "no plain background found around the head (the top and side edges of the frame "
            "are textured); give the face mask yourself"
        )
    person = cv2.morphologyEx((~background).astype(np.uint8), cv2.MORPH_OPEN, _disk(0.015 * h))
    person = _fill_holes(_largest(person > 0))
    if not person.any():
        raise MiketalkError("no head found: the frame is all plain background")
    width = person.sum(axis=1)
    rows = np.arange(h)
    top = int(np.flatnonzero(width)[0])
    widest = np.maximum.accumulate(width)
    narrowing = np.flatnonzero((rows > top) & (width < 0.85 * widest))
    bottom = h - 1
    if narrowing.size:  # else a close-up: no neck in the frame
        start = int(narrowing[0])
        wider = np.flatnonzero((rows > start) & (width > widest[start]))
        stop = int(wider[0]) if wider.size else h
        seg = width[start:stop]
        bottom = start + int(np.flatnonzero(seg <= seg.min() + 2)[0])
    head = person.copy()
    head[bottom + 1 :] = False
    return head


def _skin(frame: np.ndarray, head: np.ndarray, tolerance: float) -> np.ndarray:
    """The connected skin-coloured part of ``head`` around the centre of the lower head."""
    x, y, w, h = _extent(head)
    lab = cv2.cvtColor(cv2.GaussianBlur(frame, (0, 0), 1.0), cv2.COLOR_RGB2LAB)
    lab = lab.astype(np.float32)
    window = np.zeros(head.shape, bool)
    window[y + int(0.65 * h) : y + int(0.85 * h), x + int(0.35 * w) : x + int(0.65 * w)] = True
    sample = lab[window & head]
    if len(sample) < 20:
        raise MiketalkError("the head is too small to find the face in")
    keep = np.ones(len(sample), bool)
    for _ in range(3):  # trimmed: eyes, nostrils or a moustache in the window do not count
        mean = sample[keep].mean(axis=0)
        cov = np.cov(sample[keep].T) + 4.0 * np.eye(3)  # at least 2 Lab units of spread
        d = sample - mean
        keep = np.einsum("ni,ij,nj->n", d, np.linalg.inv(cov), d) < 2.5**2
    d = lab - mean
    dist2 = np.einsum("hwi,ij,hwj->hw", d, np.linalg.inv(cov), d)
    skin = ((dist2 < tolerance**2) & head).astype(np.uint8)
    skin = cv2.morphologyEx(skin, cv2.MORPH_OPEN, _disk(0.03 * w)) > 0
    n, labels = cv2.connectedComponents(skin.astype(np.uint8), connectivity=8)
    inside = np.bincount(labels[window], minlength=n)
    inside[0] = 0
    if inside.max() == 0:
        raise MiketalkError("no skin-coloured face found in the head")
    return labels == int(np.argmax(inside))


def locate_face(
    frame: np.ndarray, *, head: np.ndarray | None = None, tolerance: float = 4.0
) -> np.ndarray:
    """The face: the head's skin-coloured region around the nose, closed by its convex hull.

    Parameters
    ----------
    frame : numpy.ndarray
        (H, W, 3) uint8 RGB.
    head : numpy.ndarray, optional
        (H, W) bool head mask; :func:`locate_head` of ``frame`` by default.
    tolerance : float
        Mahalanobis distance (Lab) from the skin colour model that is still
        skin.

    Returns
    -------
    numpy.ndarray
        (H, W) bool: forehead below the hair, eyes, nose, cheeks, mouth and
        the jaw down to the lowest skin; not the hair, the ears' far side of
        the hull, the neck or the background.

    Raises
    ------
    MiketalkError
        As :func:`locate_head`, or if no skin-coloured region is found.
    """
    frame = _check_frame(frame, "locate_face")
    head = locate_head(frame) if head is None else np.asarray(head, bool)
    skin = _skin(frame, head, tolerance)
    hull = cv2.convexHull(np.argwhere(skin)[:, ::-1].astype(np.int32))
    face = np.zeros(skin.shape, np.uint8)
    cv2.fillConvexPoly(face, hull, 1)
    return (face > 0) & head


def _activity(frames: np.ndarray, face: np.ndarray, box: Box) -> np.ndarray:
    """Per pixel of ``box``: the median over frames of |frame - temporal median| (luma).

    Each frame is first shifted onto the first by phase correlation over the
    face, so a head that moves a few pixels does not light up its own edges.
    """
    x, y, w, h = box
    gray = _gray_stack(frames[:, y : y + h, x : x + w])
    weight = cv2.GaussianBlur(face[y : y + h, x : x + w].astype(np.float32), (0, 0), 3.0)
    window = cv2.createHanningWindow((w, h), cv2.CV_32F) * weight

    def centred(img: np.ndarray) -> np.ndarray:
        return img - float((img * weight).sum() / weight.sum())

    first = centred(gray[0])
    for k in range(1, len(gray)):
        (dx, dy), _ = cv2.phaseCorrelate(first, centred(gray[k]), window)
        shift = np.float64([[1, 0, dx], [0, 1, dy]])
        gray[k] = cv2.warpAffine(
            gray[k], shift, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_REPLICATE,
        )  # fmt: skip
    return np.median(np.abs(gray - np.median(gray, axis=0)), axis=0).astype(np.float32)


def locate_mouth(
    frames: np.ndarray,
    face: np.ndarray,
    *,
    lower_fraction: float = 0.35,
    level: float = 0.5,
) -> Box:
    """The box the mouth moves in: the lower face's most active region.

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) or (N, H, W) frames of speech, N >= 3. They are shifted
        onto the first by phase correlation over the face's box first, so the
        head's own small movements do not count; frames registered to one
        frame already (:meth:`Stabilizer.register`) do better still.
    face : numpy.ndarray
        (H, W) bool face (or head) mask of the same frames.
    lower_fraction : float
        The mouth is searched in this lowest part of the mask's height.
    level : float
        The box bounds the connected region whose activity is at least this
        fraction of the peak's.

    Returns
    -------
    tuple of int
        ``(x, y, w, h)``.

    Raises
    ------
    MiketalkError
        With fewer than 3 frames, or a mask too small to search.
    """
    frames = np.asarray(frames)
    if frames.ndim < 3 or frames.shape[0] < 3:
        raise MiketalkError(f"locate_mouth needs at least 3 frames, got shape {frames.shape}")
    face = _fill_holes(np.asarray(face, bool))
    box = _extent(face)
    fx, fy, fw, fh = box
    activity = cv2.GaussianBlur(_activity(frames, face, box), (0, 0), max(1.0, 0.04 * fw))
    region = cv2.erode(face[fy : fy + fh, fx : fx + fw].astype(np.uint8), _disk(0.08 * fw)) > 0
    region[: round((1 - lower_fraction) * fh)] = False
    region[:, : round(0.2 * fw)] = False  # a frontal face's mouth is in its middle,
    region[:, round(0.8 * fw) :] = False  # away from the hair and ears at its sides
    if not region.any():
        raise MiketalkError("the face is too small to find the mouth in")
    score = np.where(region, activity, -1.0)
    py, px = np.unravel_index(int(np.argmax(score)), score.shape)
    hot = ((score >= level * score[py, px]) & region).astype(np.uint8)
    _, labels = cv2.connectedComponents(hot, connectivity=8)
    x, y, w, h = _extent(labels == labels[py, px])
    return x + fx, y + fy, w, h


def _eye_rows(mouth_box: Box) -> tuple[int, int]:
    """Top and bottom row of the eyes and brows: 1.4 to 0.8 mouth widths above the mouth.

    A face's proportions, not a detector: the eyes' line lies about one mouth
    width above the mouth, the brows a little higher (on GRID's talker: eyes
    and brows in rows 146-174, this rule 144-172).
    """
    _, y, w, _ = mouth_box
    return max(0, y - round(1.4 * w)), max(0, y - round(0.8 * w))


def registration_mask(
    face: np.ndarray,
    mouth_box: Box,
    *,
    region: Region = "central",
    margin: float = 0.1,
    edge: float = 0.06,
) -> np.ndarray:
    """The part of the face to register (or measure) on: the face outside the mouth.

    Parameters
    ----------
    face : numpy.ndarray
        (H, W) bool, :func:`locate_face`.
    mouth_box : tuple of int
        ``(x, y, w, h)``, :func:`locate_mouth`.
    region : {"central", "face", "rigid"}
        ``"face"``: the face minus the mouth zone (the mouth box grown by
        ``margin`` face widths, down to the bottom of the face: the chin
        moves with the jaw). ``"central"``: that without the forehead above
        the brows (hair covers it differently in different sessions).
        ``"rigid"``: only the band between the eyes and the mouth zone (no
        eyes, brows, forehead or jaw).
    margin : float
        Around the mouth box, in face widths.
    edge : float
        Distance kept from the face's outline, in face widths.

    Returns
    -------
    numpy.ndarray
        (H, W) bool.

    Raises
    ------
    MiketalkError
        If the mask comes out empty or ``region`` is unknown.
    """
    if region not in ("face", "central", "rigid"):
        raise MiketalkError(f"unknown region {region!r}: use face, central or rigid")
    face = np.asarray(face, bool)
    fw = _extent(face)[2]
    x, y, w, _ = mouth_box
    m = round(margin * fw)
    mask = cv2.erode(face.astype(np.uint8), _disk(2 * edge * fw)) > 0 if edge > 0 else face.copy()
    mask[max(0, y - m) :, max(0, x - m) : x + w + m] = False
    if region != "face":
        top, bottom = _eye_rows(mouth_box)
        mask[:top] = False
        mask[max(0, y - m) :] = False
        if region == "rigid":
            mask[: bottom + m // 2] = False
    if not mask.any():
        raise MiketalkError(f"the {region} registration mask is empty")
    return mask


def choose_reference(frames: np.ndarray, *, lead: int = 10) -> int:
    """The frame nearest the median of the first ``lead`` frames (a clip's opening silence).

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) or (N, H, W).
    lead : int
        How many opening frames to choose from (10 at 25 fps: GRID's
        opening silence is 0.5 to 1 s).

    Returns
    -------
    int
        Index into ``frames``: mouth at rest, eyes open, head still.
    """
    frames = np.asarray(frames)
    if frames.ndim < 3 or frames.shape[0] == 0:
        raise MiketalkError("choose_reference needs at least one frame")
    gray = _gray_stack(frames[: max(1, lead)])
    return int(np.argmin(np.abs(gray - np.median(gray, axis=0)).mean(axis=(1, 2))))


# --- registration --------------------------------------------------------------------------


def _hom(w: np.ndarray) -> np.ndarray:
    out = np.eye(3)
    out[:2] = w
    return out


def _to_level(scale: float, x0: int, y0: int) -> np.ndarray:
    """3x3 map from full-size frame coordinates to a crop at ``(x0, y0)`` resized by ``scale``."""
    c = (scale - 1) / 2  # pixel centres: INTER_AREA at 1/2 averages pixels 2i and 2i+1
    return np.array([[scale, 0, c - scale * x0], [0, scale, c - scale * y0], [0, 0, 1.0]])


def _aligned_box(
    x0: int, y0: int, x1: int, y1: int, q: int, w: int, h: int
) -> tuple[int, int, int, int]:
    """The box clipped to the frame, its size cut to a multiple of ``q``."""
    x0, y0, x1, y1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
    return x0, y0, x0 + (x1 - x0) // q * q, y0 + (y1 - y0) // q * q


@dataclass(frozen=True)
class _Level:
    scale: float
    template: np.ndarray  # float32 crop of the reference's luma at this scale
    mask: np.ndarray  # uint8 0/255, same size
    ref_to_tmpl: np.ndarray  # 3x3: full-size reference coordinates -> template crop
    tmpl_to_ref: np.ndarray
    frame_to_input: np.ndarray  # 3x3: full-size frame coordinates -> input crop
    input_to_frame: np.ndarray
    input_size: tuple[int, int]  # (w, h) of the input crop at this scale
    criteria: tuple[int, int, float]


def _ecc(
    level: _Level, mask: np.ndarray, image: np.ndarray, warp: np.ndarray, blur: int
) -> tuple[float, np.ndarray]:
    """One ECC run at ``level``: the template's pixels under ``mask`` against ``image``.

    The mask belongs to the template (``cv2.findTransformECCWithMask``, OpenCV
    4.13 and later): older OpenCV only takes a mask on the input image, so it
    gets the template's carried over by the start warp, which is biased (on a
    synthetic face moved by a known transform, 0.3 to 0.5 px off where the
    template mask is 0.03 px off).
    """
    if _WITH_MASK:
        ones = np.full(image.shape, 255, np.uint8)
        rho, warp = cv2.findTransformECCWithMask(
            level.template, image, mask, ones, warp, cv2.MOTION_AFFINE, level.criteria, blur
        )
    else:  # pragma: no cover - OpenCV < 4.13
        in_mask = cv2.warpAffine(mask, warp, level.input_size, flags=cv2.INTER_NEAREST)
        rho, warp = cv2.findTransformECC(
            level.template, image, warp, cv2.MOTION_AFFINE, level.criteria, in_mask, blur
        )
    return float(rho), warp


_WITH_MASK = hasattr(cv2, "findTransformECCWithMask")


@dataclass(frozen=True)
class Stabilized:
    """A clip registered to the reference: :meth:`Stabilizer.stabilize`'s result.

    Attributes
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8, the stabilized frames.
    transforms : numpy.ndarray
        (N, 2, 3) affine maps from reference pixel coordinates to the frame's.
    field : numpy.ndarray or None
        (H, W, 2) float32 conform field (reference pixel offsets), or None.
    correlations : numpy.ndarray
        (N,) ECC correlation coefficient of each frame.
    """

    frames: np.ndarray
    transforms: np.ndarray
    field: np.ndarray | None
    correlations: np.ndarray


class Stabilizer:
    """Registers frames to one reference frame on a mask (the face outside the mouth).

    Parameters
    ----------
    reference : numpy.ndarray
        (H, W, 3) uint8 RGB (or (H, W)) reference frame.
    mask : numpy.ndarray
        (H, W) bool, where to register (:func:`registration_mask`).
    levels : int
        Pyramid levels (2: half size, then full size).
    iterations : tuple of int
        ECC iteration limit per level, coarse to fine.
    epsilon : float
        ECC stops when the correlation improves by less than this.
    blur : int
        ECC's Gaussian pre-filter size (odd; MPEG noise).
    search : int
        How far (full-size pixels) beyond the mask the frame is searched.
    min_correlation : float
        Below this ECC correlation coefficient a frame does not register.
    interpolation : int
        OpenCV interpolation for :meth:`apply` (``cv2.INTER_LINEAR``).
    conform_degree : int
        Degree of the polynomial conform field (0: no field).
    max_conform : float
        Largest conform offset, in widths of the conform mask, before a clip
        is taken not to show the reference's face.
    outlier_factor : float
        After ECC, pixels whose normalized difference from the reference
        exceeds this many times the median are left out and ECC runs once
        more at full size (0: no second run).
    conform_mask : numpy.ndarray, optional
        (H, W) bool, where :meth:`conform` fits its field (``mask`` by
        default; :meth:`from_reference` gives the face below the brows
        outside the mouth zone).

    Attributes
    ----------
    correlations : numpy.ndarray
        The last :meth:`register` call's per-frame ECC correlations.
    face, mouth_box : set by :meth:`from_reference` (None otherwise).
    """

    def __init__(
        self,
        reference: np.ndarray,
        mask: np.ndarray,
        *,
        levels: int = 2,
        iterations: tuple[int, ...] = (30, 15),
        epsilon: float = 1e-4,
        blur: int = 5,
        search: int = 32,
        min_correlation: float = 0.8,
        interpolation: int = cv2.INTER_LINEAR,
        conform_degree: int = 3,
        max_conform: float = 0.25,
        outlier_factor: float = 3.0,
        conform_mask: np.ndarray | None = None,
    ) -> None:
        self.reference = np.asarray(reference)
        self.mask = np.asarray(mask, bool)
        if self.reference.shape[:2] != self.mask.shape:
            raise MiketalkError(
                f"mask {self.mask.shape} and reference {self.reference.shape[:2]} differ in size"
            )
        if levels < 1:
            raise MiketalkError(f"levels must be at least 1, got {levels}")
        self.min_correlation = min_correlation
        self.interpolation = interpolation
        self.conform_degree = conform_degree
        self.max_conform = max_conform
        self.outlier_factor = outlier_factor
        self.conform_mask = self.mask if conform_mask is None else np.asarray(conform_mask, bool)
        if self.conform_mask.shape != self.mask.shape or not self.conform_mask.any():
            raise MiketalkError("conform_mask must be a non-empty mask of the reference's size")
        self.blur = blur
        self.correlations = np.empty(0)
        self.face: np.ndarray | None = None
        self.mouth_box: Box | None = None
        h, w = self.mask.shape
        q = 2 ** (levels - 1)
        x, y, bw, bh = _extent(self.mask)
        tx0, ty0, tx1, ty1 = _aligned_box(x - 2, y - 2, x + bw + 2, y + bh + 2, q, w, h)
        box = (x - search, y - search, x + bw + search, y + bh + search)
        ix0, iy0, ix1, iy1 = _aligned_box(*box, q, w, h)
        self._input_box = (ix0, iy0, ix1, iy1)
        gray = _gray(self.reference)
        tmpl = gray[ty0:ty1, tx0:tx1]
        tmask = self.mask[ty0:ty1, tx0:tx1].astype(np.float32)
        iters = (*iterations, *(iterations[-1:] * levels))
        self._levels: list[_Level] = []
        for k in range(levels - 1, -1, -1):
            s = 0.5**k
            t, m = tmpl, tmask
            if k:
                t = cv2.resize(tmpl, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
                m = cv2.resize(tmask, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
            count = iters[levels - 1 - k]
            to_tmpl, to_input = _to_level(s, tx0, ty0), _to_level(s, ix0, iy0)
            self._levels.append(
                _Level(
                    scale=s,
                    template=np.ascontiguousarray(t),
                    mask=np.where(m > 0.5, 255, 0).astype(np.uint8),
                    ref_to_tmpl=to_tmpl,
                    tmpl_to_ref=np.linalg.inv(to_tmpl),
                    frame_to_input=to_input,
                    input_to_frame=np.linalg.inv(to_input),
                    input_size=((ix1 - ix0) // 2**k, (iy1 - iy0) // 2**k),
                    criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, count, epsilon),
                )
            )
        self._ref_pyramid = self._pyramid(gray)
        self._basis: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    @classmethod
    def from_reference(
        cls,
        reference: np.ndarray,
        *,
        sample: np.ndarray | None = None,
        face: np.ndarray | None = None,
        mouth_box: Box | None = None,
        region: Region = "central",
        **settings,
    ) -> Stabilizer:
        """A stabilizer for ``reference``, finding the face and the mouth itself.

        Parameters
        ----------
        reference : numpy.ndarray
            (H, W, 3) uint8 RGB reference frame (:func:`choose_reference`).
        sample : numpy.ndarray, optional
            (N, H, W, 3) frames of speech of the same person (the reference's
            clip, say) to find the mouth in: they are first registered on the
            whole face, then :func:`locate_mouth` runs on them. Needed unless
            ``mouth_box`` is given.
        face : numpy.ndarray, optional
            (H, W) bool; :func:`locate_face` of the reference by default.
        mouth_box : tuple of int, optional
            ``(x, y, w, h)`` in the reference.
        region : {"central", "face", "rigid"}
            What to register on (:func:`registration_mask`).
        **settings
            Keyword settings of :class:`Stabilizer`.

        Returns
        -------
        Stabilizer
            With ``face`` and ``mouth_box`` set.

        Raises
        ------
        MiketalkError
            If neither ``sample`` nor ``mouth_box`` is given, or as the
            functions it calls.
        """
        reference = _check_frame(reference, "Stabilizer.from_reference")
        face = locate_face(reference) if face is None else np.asarray(face, bool)
        if mouth_box is None:
            if sample is None:
                raise MiketalkError("give mouth_box, or sample frames of speech to find it in")
            rough = cls(reference, face, **{**settings, "conform_degree": 0})
            transforms = rough.register(sample, clip="the sample", on_failure="nan")
            ok = np.isfinite(transforms[:, 0, 0])
            mouth_box = locate_mouth(rough.apply(sample[ok], transforms[ok]), face)
        mask = registration_mask(face, mouth_box, region=region)
        if (
            "conform_mask" not in settings
        ):  # the mouth between the cheeks: interpolated, not extrapolated
            top, _ = _eye_rows(mouth_box)
            settings["conform_mask"] = registration_mask(face, mouth_box, region="face")
            settings["conform_mask"][:top] = False
        out = cls(reference, mask, **settings)
        out.face = face
        out.mouth_box = tuple(int(v) for v in mouth_box)  # type: ignore[assignment]
        return out

    # -- per frame --

    def _pyramid(self, gray: np.ndarray) -> list[np.ndarray]:
        ix0, iy0, ix1, iy1 = self._input_box
        crop = np.ascontiguousarray(gray[iy0:iy1, ix0:ix1])
        return [
            crop
            if level.scale == 1
            else cv2.resize(crop, level.input_size, interpolation=cv2.INTER_AREA)
            for level in self._levels
        ]

    def _phase_start(self, pyramid: list[np.ndarray]) -> np.ndarray:
        """A translation found by phase correlation at the coarsest level."""
        level = self._levels[0]
        ref, img = self._ref_pyramid[0], pyramid[0]
        window = cv2.createHanningWindow((ref.shape[1], ref.shape[0]), cv2.CV_32F)
        (dx, dy), _ = cv2.phaseCorrelate(ref - ref.mean(), img - img.mean(), window)
        out = np.eye(3)
        out[:2, 2] = dx / level.scale, dy / level.scale
        return out

    def _register_one(
        self, pyramid: list[np.ndarray], warp: np.ndarray
    ) -> tuple[float, np.ndarray]:
        rho = 0.0
        for level, image in zip(self._levels, pyramid, strict=True):
            w32 = (level.frame_to_input @ warp @ level.tmpl_to_ref)[:2].astype(np.float32)
            rho, w32 = _ecc(level, level.mask, image, w32, self.blur)
            warp = level.input_to_frame @ _hom(w32) @ level.ref_to_tmpl
        if self.outlier_factor > 0:
            rho, warp = self._reweighted(pyramid[-1], warp, rho)
        return float(rho), warp

    def _reweighted(
        self, image: np.ndarray, warp: np.ndarray, rho: float
    ) -> tuple[float, np.ndarray]:
        """Register again at full size without the pixels that do not match (a blink, say)."""
        level = self._levels[-1]
        w32 = (level.frame_to_input @ warp @ level.tmpl_to_ref)[:2].astype(np.float32)
        t = level.template
        size = (t.shape[1], t.shape[0])
        warped = cv2.warpAffine(image, w32, size, flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
        inside = level.mask > 0
        a, b = t[inside], warped[inside]
        err = np.zeros(t.shape, np.float32)
        err[inside] = np.abs((a - a.mean()) / (a.std() + 1e-6) - (b - b.mean()) / (b.std() + 1e-6))
        err = cv2.GaussianBlur(err, (0, 0), 2.0)
        bad = inside & (err > self.outlier_factor * float(np.median(err[inside])))
        if not bad.any():
            return rho, warp
        bad = cv2.dilate(bad.astype(np.uint8), _disk(5)) > 0
        keep = np.where(inside & ~bad, 255, 0).astype(np.uint8)
        if (keep > 0).sum() < 0.5 * inside.sum():
            return rho, warp
        rho, w32 = _ecc(level, keep, image, w32, self.blur)
        return float(rho), level.input_to_frame @ _hom(w32) @ level.ref_to_tmpl

    def register(
        self,
        frames: np.ndarray,
        *,
        clip: str = "clip",
        init: np.ndarray | None = None,
        on_failure: Literal["raise", "nan"] = "raise",
    ) -> np.ndarray:
        """Affine transforms registering each frame to the reference.

        Parameters
        ----------
        frames : numpy.ndarray
            (N, H, W, 3) uint8 RGB (or (N, H, W)), the reference's size.
        clip : str
            Name used in error messages.
        init : numpy.ndarray, optional
            (2, 3) start for the first frame (default: phase correlation).
        on_failure : {"raise", "nan"}
            A frame that does not register raises, or gets a NaN transform
            (and the next frame starts afresh).

        Returns
        -------
        numpy.ndarray
            (N, 2, 3) float64 ``T``: reference pixel ``(x, y)`` shows in the
            frame at ``T @ (x, y, 1)``. :attr:`correlations` holds each
            frame's ECC correlation.

        Raises
        ------
        MiketalkError
            Naming the clip and frame, if ECC does not converge or the
            correlation is below ``min_correlation`` (``on_failure="raise"``).
        """
        frames = np.asarray(frames)
        if frames.ndim not in (3, 4) or frames.shape[1:3] != self.mask.shape:
            raise MiketalkError(
                f"{clip}: frames of shape {frames.shape[1:3]} do not match the reference's "
                f"{self.mask.shape}"
            )
        n = frames.shape[0]
        out = np.empty((n, 2, 3))
        self.correlations = np.full(n, np.nan)
        warp = None if init is None else _hom(init)
        for i in range(n):
            pyramid = self._pyramid(_gray(frames[i]))
            rho, found = -1.0, None
            for start in (warp, None) if warp is not None else (None,):
                try:
                    rho, found = self._register_one(
                        pyramid, self._phase_start(pyramid) if start is None else start
                    )
                except cv2.error:
                    rho, found = -1.0, None
                if rho >= self.min_correlation:
                    break
            self.correlations[i] = rho
            if found is None or rho < self.min_correlation:
                if on_failure == "nan":
                    out[i], warp = np.nan, None
                    continue
                why = "ECC did not converge" if found is None else f"correlation {rho:.3f}"
                raise MiketalkError(
                    f"{clip} frame {i} does not register to the reference: {why} "
                    f"(at least {self.min_correlation} needed)"
                )
            warp = found
            out[i] = warp[:2]
        return out

    # -- per clip --

    def _conform_basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Polynomial basis over the frame, its pseudo-inverse on the mask, and the fade."""
        if self._basis is None:
            h, w = self.mask.shape
            x, y, bw, bh = _extent(self.conform_mask)
            scale = max(bw, bh) / 2
            yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
            u, v = (xx - (x + bw / 2)) / scale, (yy - (y + bh / 2)) / scale
            d = self.conform_degree
            basis = np.stack(
                [(u**i * v**j).ravel() for i in range(d + 1) for j in range(d + 1 - i)], axis=1
            )
            pinv = np.linalg.pinv(basis[self.conform_mask.ravel()].astype(np.float64))
            fade = np.zeros((h, w), np.float32)
            grow = round(0.25 * max(bw, bh))
            fade[max(0, y - grow) : y + bh + grow, max(0, x - grow) : x + bw + grow] = 1
            fade = cv2.GaussianBlur(fade, (0, 0), grow / 2)
            self._basis = (basis, pinv.astype(np.float32), fade)
        return self._basis

    def conform(
        self, frames: np.ndarray, transforms: np.ndarray, *, clip: str = "clip"
    ) -> np.ndarray | None:
        """The clip's smooth field carrying the reference's face onto the clip's.

        Parameters
        ----------
        frames : numpy.ndarray
            (N, H, W, 3) the clip's frames.
        transforms : numpy.ndarray
            (N, 2, 3) from :meth:`register` (NaN rows are left out).
        clip : str
            Name used in error messages.

        Returns
        -------
        numpy.ndarray or None
            (H, W, 2) float32 offsets ``F``: reference pixel ``p`` is taken
            from the affinely stabilized clip at ``p + F(p)``. None if
            ``conform_degree`` is 0.

        Raises
        ------
        MiketalkError
            If no frame registered, or the field exceeds ``max_conform`` face
            widths on the mask.
        """
        if self.conform_degree <= 0:
            return None
        ok = np.isfinite(transforms[:, 0, 0])
        if not ok.any():
            raise MiketalkError(f"{clip}: no frame registered, nothing to conform")
        x, y, bw, bh = _extent(self.conform_mask)
        pad = round(0.1 * max(bw, bh))
        ys = slice(max(0, y - pad), y + bh + pad)
        xs = slice(max(0, x - pad), x + bw + pad)
        steady = self.apply(frames[ok], transforms[ok])[:, ys, xs]
        median = np.median(_gray_stack(steady), axis=0)
        ref_crop = np.ascontiguousarray(_u8gray(self.reference)[ys, xs])
        dis = cv2.DISOpticalFlow_create(cv2.DISOpticalFlow_PRESET_MEDIUM)
        flow = np.zeros((*self.mask.shape, 2), np.float32)
        flow[ys, xs] = dis.calc(ref_crop, np.clip(median + 0.5, 0, 255).astype(np.uint8), None)
        basis, pinv, fade = self._conform_basis()
        coef = pinv @ flow.reshape(-1, 2)[self.conform_mask.ravel()]
        field = (basis @ coef).reshape(*self.mask.shape, 2) * fade[..., None]
        largest = float(np.sqrt((field[self.conform_mask] ** 2).sum(axis=1)).max())
        if largest > self.max_conform * bw:
            raise MiketalkError(
                f"{clip} does not register to the reference: its face differs by {largest:.1f} "
                f"px after the affine registration (at most {self.max_conform * bw:.1f})"
            )
        return field.astype(np.float32)

    def apply(
        self, frames: np.ndarray, transforms: np.ndarray, *, field: np.ndarray | None = None
    ) -> np.ndarray:
        """Warp frames onto the reference.

        Parameters
        ----------
        frames : numpy.ndarray
            (N, H, W, 3) or (N, H, W).
        transforms : numpy.ndarray
            (N, 2, 3) from :meth:`register`.
        field : numpy.ndarray, optional
            (H, W, 2) from :meth:`conform`, applied before the transforms.

        Returns
        -------
        numpy.ndarray
            Frames like ``frames``: output pixel ``p`` is the frame at
            ``T @ (p + F(p))`` (bilinear by default; the edges replicated).
        """
        frames = np.asarray(frames)
        out = np.empty_like(frames)
        h, w = frames.shape[1:3]
        if field is None:
            flags = self.interpolation | cv2.WARP_INVERSE_MAP
            for i in range(frames.shape[0]):
                out[i] = cv2.warpAffine(
                    frames[i], transforms[i], (w, h), flags=flags, borderMode=cv2.BORDER_REPLICATE
                )
            return out
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        px, py = xx + field[..., 0], yy + field[..., 1]
        for i in range(frames.shape[0]):
            t = transforms[i].astype(np.float32)
            map_x = t[0, 0] * px + t[0, 1] * py + t[0, 2]
            map_y = t[1, 0] * px + t[1, 1] * py + t[1, 2]
            out[i] = cv2.remap(
                frames[i], map_x, map_y, self.interpolation, borderMode=cv2.BORDER_REPLICATE
            )
        return out

    def stabilize(self, frames: np.ndarray, *, clip: str = "clip") -> Stabilized:
        """Register, conform and warp one clip (:meth:`register`, :meth:`conform`, :meth:`apply`).

        Raises
        ------
        MiketalkError
            If a frame does not register, or the clip does not conform.
        """
        transforms = self.register(frames, clip=clip)
        correlations = self.correlations.copy()
        field = self.conform(frames, transforms, clip=clip)
        return Stabilized(
            self.apply(frames, transforms, field=field), transforms, field, correlations
        )


# --- measurement ---------------------------------------------------------------------------


def residual_motion(frames: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per frame, the mean optical-flow magnitude (pixels) over ``mask`` from ``reference``.

    The flow is OpenCV's DIS (Kroeger et al. 2016) at its ``MEDIUM`` preset,
    on luma, from the reference to the frame, over the whole frame (so the
    flow at the mask's edge sees its surroundings); the magnitude is averaged
    over the mask's pixels.

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8 RGB or (N, H, W) uint8.
    reference : numpy.ndarray
        (H, W, 3) or (H, W) uint8.
    mask : numpy.ndarray
        (H, W) bool.

    Returns
    -------
    numpy.ndarray
        (N,) float64 pixels.
    """
    dis = cv2.DISOpticalFlow_create(cv2.DISOpticalFlow_PRESET_MEDIUM)
    ref = _u8gray(reference)
    m = np.asarray(mask, bool)
    if not m.any():
        raise MiketalkError("residual_motion: the mask is empty")
    out = np.empty(len(frames))
    for i, frame in enumerate(frames):
        flow = dis.calc(ref, _u8gray(frame), None)[m]
        out[i] = float(np.sqrt((flow * flow).sum(axis=1)).mean())
    return out
