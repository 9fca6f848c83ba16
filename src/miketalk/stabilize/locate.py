"""Where the head, face and mouth are in a frontal talking head, and the mask to register on.

No learned landmark model: every rule is a property of a frontal talking head in
front of a plain background (see :mod:`miketalk.stabilize` for the rules).
"""

from __future__ import annotations

from typing import Literal

import cv2
import numpy as np

from miketalk.errors import MiketalkError

Box = tuple[int, int, int, int]


Region = Literal["face", "central", "rigid"]


_LUMA = np.array([[0.299, 0.587, 0.114]], np.float32)  # BT.601, as cv2.COLOR_RGB2GRAY


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
