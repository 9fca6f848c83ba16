"""A video's frames registered to a model's reference, and checked to show its person.

:func:`register_video` registers frames of the reference's size (a video's frames scaled
to it, or its face crops, :mod:`miketalk.track`) with the model's stabilizer: the first
usable frame alone first (a video whose first frame does not register does not show the
model's person), then all of them in chunks, each starting from the last registered
frame; frames that do not register take the nearest registered frame's transform, and
the transforms are smoothed in time. It finds the blinks and the light (the median of
the registered frames), and refuses a video whose mouth and chin do not land on the
model's, or whose face's colour the model's mouth cannot match.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from miketalk import defaults
from miketalk.composite.loop import smooth_in_time
from miketalk.errors import MiketalkError

__all__ = [
    "BLINK_FACTOR",
    "MIN_LOWER_FACE",
    "Registration",
    "eye_band",
    "find_blinks",
    "lower_face_correlation",
    "register_video",
]

#: The least correlation of a video's lower face (stabilized, the median over its frames)
#: with the model's reference: the 16 committed GRID clips checked score 0.63 to 0.96, the
#: same man mirrored (registered wrongly, at ECC correlation 0.91) 0.12.
MIN_LOWER_FACE = 0.4

#: A frame blinks when its eye band differs from the sequence's median by this many
#: times the band's median difference (and at least 3 grey levels).
BLINK_FACTOR = 3.0


@dataclass(frozen=True)
class Registration:
    """A video's frames registered to a model's reference (:func:`register_video`).

    Attributes
    ----------
    transforms : numpy.ndarray
        ``(N, 2, 3)``: reference pixel ``p`` shows in registered frame ``i`` at
        ``transforms[i] @ (p + field(p), 1)``; frames that did not register take the
        nearest registered frame's, and all are smoothed in time.
    field : numpy.ndarray or None
        The conform field.
    blinks : tuple of int
        Frames where the eyes are closed or closing.
    steady : numpy.ndarray
        ``(h, w, 3)`` the median of the frames stabilized onto the reference.
    steady_shots : dict of int to numpy.ndarray, optional
        With ``shots``: each shot's own median (its light).
    """

    transforms: np.ndarray
    field: np.ndarray | None
    blinks: tuple[int, ...]
    steady: np.ndarray
    steady_shots: dict[int, np.ndarray] | None = None


def register_video(
    frames,
    fps: float,
    stabilizer,
    *,
    source: str = "the video",
    progress: bool = False,
    smooth: float = defaults.BACKGROUND_SMOOTH,
    usable: np.ndarray | None = None,
    scaled: str = "",
    refine: bool = False,
    shots: np.ndarray | None = None,
) -> Registration:
    """Register frames of the reference's size to the model's reference, and check them.

    Parameters
    ----------
    frames : numpy.ndarray
        ``(N, h, w, 3)`` uint8 RGB at the reference's size (a video's frames scaled to
        it, or its face crops).
    fps : float
    stabilizer : miketalk.stabilize.Stabilizer
        The model's.
    source : str
        Named in errors.
    progress : bool
        Draw a progress bar of the registration on stderr.
    smooth : float
        Gaussian sigma in seconds of the transforms smoothed in time.
    usable : numpy.ndarray, optional
        ``(N,)`` bool: the frames that may register at all (a face crop whose face was
        not tracked is not the face); all by default.
    scaled : str
        Said after a first frame that does not register (why it might not).
    refine : bool
        The frames are face crops a tracker vouches for (:mod:`miketalk.track`): ECC
        refines them, and a usable frame that does not register keeps the crop's own
        pixels (the identity) instead of being left out; the lower face's correlation with
        the reference is not asked for (the tracker placed the mouth), nor is a second
        copy of the face looked for in the crop (the tracker counted the faces).
    shots : numpy.ndarray, optional
        ``(N,)`` int, the shot of each frame (-1: none): each shot's median is also
        kept (:attr:`Registration.steady_shots`), the light its mouth's colour is
        matched to.

    Raises
    ------
    MiketalkError
        When the first usable frame, or fewer than half of all frames, register, or the
        registered mouth, chin or colour are not the model's: the video does not show
        the model's person frontally (or no one).
    """
    usable = np.ones(len(frames), bool) if usable is None else np.asarray(usable, bool)
    if not usable.any():
        raise MiketalkError(f"{source}: no frame shows one frontal face")
    start = int(np.flatnonzero(usable)[0])
    from miketalk.track.refine import refine_crops

    first = stabilizer.register(frames[start : start + 1], clip=source, on_failure="nan")
    if refine:
        first = refine_crops(first, usable[start : start + 1], stabilizer)[0]
    if not np.isfinite(first).all():
        rho = float(stabilizer.correlations[0])
        why = (
            "no registration to the model's reference converges"
            if rho < 0
            else f"correlation {rho:.2f} with the model's reference, at least "
            f"{stabilizer.min_correlation} needed"
        )
        raise MiketalkError(
            f"{source}: its {'first frame' if start == 0 else f'frame {start}'} does not show "
            f"the model's person ({why}{scaled}): give a frontal video of the same person"
        )
    from miketalk.composite.video_checks import SECOND_FACE, face_matches
    from miketalk.track.refine import refine_crops

    # a tracker's crops show one face (its detector counted the faces in the whole frame,
    # and left out the frames with several); in a crop, the face's own shifted copy
    # matches the reference at 0.44 to 0.62 (the weekly addresses): no second face
    peaks = [] if refine else face_matches(frames[start], stabilizer, first[0])
    if len(peaks) > 1 and peaks[1] >= SECOND_FACE:
        raise MiketalkError(
            f"{source}: its first frame shows the model's face twice (a second place matches "
            f"it at {peaks[1]:.2f}, at least {SECOND_FACE} counts): give a video of one person"
        )
    transforms = _register(stabilizer, frames, first[0], source=source, progress=progress)
    if refine:
        transforms = refine_crops(transforms, usable, stabilizer)[0]
    transforms[~usable] = np.nan
    ok = np.isfinite(transforms[:, 0, 0])
    if ok.mean() < 0.5:
        raise MiketalkError(
            f"{source}: only {int(ok.sum())} of its {len(ok)} frames show the model's person "
            "(register to its reference): give a frontal video of the same person"
        )
    some = _spread(len(frames), _SAMPLE)  # the field and the light from at most _SAMPLE frames
    field = stabilizer.conform(frames[some], transforms[some], clip=source)
    transforms = _fill(transforms)
    if smooth > 0 and len(transforms) > 1:
        transforms = smooth_in_time(transforms, smooth * fps)
    picked = {}  # each shot's frames its light is measured on
    if shots is not None:
        for shot in np.unique(shots[shots >= 0]):
            frames_of = np.flatnonzero(shots == shot)
            picked[int(shot)] = frames_of[_spread(len(frames_of), _SAMPLE)]
    kept = np.unique(np.concatenate([some, *picked.values()]))
    band, steady = _stabilized(stabilizer, frames, transforms, field, kept)
    blinks = _blinks_of(band)
    median = np.median(steady[np.searchsorted(kept, some)], axis=0).astype(np.uint8)
    score = lower_face_correlation(median, stabilizer.reference, stabilizer.mouth_box)
    # tracked crops: the landmarks put the mouth in place; another session's light and
    # shadows are not another face (the weekly addresses' shots score -0.21 to 0.9)
    if score < MIN_LOWER_FACE and not refine:
        raise MiketalkError(
            f"{source}: its mouth and chin do not land on the model's (correlation {score:.2f} "
            f"with the model's reference after registration, at least {MIN_LOWER_FACE} needed): "
            "give a frontal video of the same person"
        )
    _check_colour(median, stabilizer, source)
    by_shot = None
    if shots is not None:  # each shot's own light (the addresses' differ from shot to shot)
        by_shot = {
            shot: np.median(steady[np.searchsorted(kept, at)], axis=0).astype(np.uint8)
            for shot, at in picked.items()
        }
    return Registration(transforms, field, blinks, median, by_shot)


#: Frames stabilized at a time: only their eye band and the frames the light is measured on
#: are kept, so memory does not grow with the video's length (a stabilized copy of every
#: frame did).
_CHUNK = 50


def _stabilized(stabilizer, frames, transforms, field, kept: np.ndarray):
    """Every frame's eye band (:func:`eye_band`) on the reference, and the frames ``kept``
    (sorted indices) stabilized whole, the frames stabilized :data:`_CHUNK` at a time."""
    bands, whole = [], []
    for start in range(0, len(frames), _CHUNK):
        part = stabilizer.apply(
            frames[start : start + _CHUNK], transforms[start : start + _CHUNK], field=field
        )
        bands.append(eye_band(part, stabilizer.mouth_box))
        here = kept[(kept >= start) & (kept < start + len(part))]
        whole.append(part[here - start])
    return np.concatenate(bands), np.concatenate(whole)


def lower_face_correlation(
    steady: np.ndarray, reference: np.ndarray, mouth_box: tuple[int, int, int, int]
) -> float:
    """Normalized cross-correlation (luma) of two frames over the lips and chin.

    The box is 1 mouth width either side of the mouth box's centre, from 0.45
    above it to 0.8 below: where a registered video's mouth must land for the
    composited mouth to cover it.
    """
    import cv2

    x, y, w, h = mouth_box
    cx, cy = x + w / 2, y + h / 2
    rows = slice(max(0, round(cy - 0.45 * w)), round(cy + 0.8 * w))
    cols = slice(max(0, round(cx - w)), round(cx + w))
    a, b = (
        cv2.cvtColor(np.ascontiguousarray(f), cv2.COLOR_RGB2GRAY)[rows, cols].astype(np.float64)
        for f in (steady, reference)
    )
    a, b = a - a.mean(), b - b.mean()
    norm = float(np.sqrt((a * a).sum() * (b * b).sum()))
    return float((a * b).sum() / norm) if norm > 0 else 0.0


def find_blinks(
    stabilized: np.ndarray, mouth_box: tuple[int, int, int, int], *, factor: float = BLINK_FACTOR
) -> tuple[int, ...]:
    """Frames whose eyes differ from the sequence's usual eyes: blinks.

    Parameters
    ----------
    stabilized : numpy.ndarray
        (N, H, W, 3) frames on the reference.
    mouth_box : tuple of int
        The mouth box: the eyes are 0.8 to 1.4 mouth widths above it (a face's
        proportions, as :mod:`miketalk.stabilize` uses them), across
        two mouth widths about its centre.
    factor : float
        See :data:`BLINK_FACTOR`.
    """
    return _blinks_of(eye_band(stabilized, mouth_box), factor=factor)


def eye_band(stabilized: np.ndarray, mouth_box: tuple[int, int, int, int]) -> np.ndarray:
    """``(N, h, w)`` float32 grey: the eyes' band of frames on the reference (0.8 to 1.4 mouth
    widths above the mouth box, two mouth widths about its centre)."""
    x, y, w, _ = mouth_box
    top, bottom = max(0, y - round(1.4 * w)), max(1, y - round(0.8 * w))
    left, right = max(0, round(x + w / 2 - 1.2 * w)), round(x + w / 2 + 1.2 * w)
    return stabilized[:, top:bottom, left:right].astype(np.float32).mean(axis=3)


def _blinks_of(band: np.ndarray, *, factor: float = BLINK_FACTOR) -> tuple[int, ...]:
    """The frames whose eye band (:func:`eye_band`) differs from the usual (see
    :func:`find_blinks`)."""
    change = np.abs(band - np.median(band, axis=0)).mean(axis=(1, 2))
    threshold = max(factor * float(np.median(change)), 3.0)
    return tuple(int(i) for i in np.flatnonzero(change > threshold))


#: Frames a long video's conform field and light are measured on (evenly spread).
_SAMPLE = 100


def _spread(n: int, most: int) -> np.ndarray:
    """At most ``most`` indices spread evenly over ``range(n)`` (all of them for ``n <= most``)."""
    return np.arange(n) if n <= most else np.linspace(0, n - 1, most).round().astype(int)


def _fill(transforms: np.ndarray) -> np.ndarray:
    """NaN transforms replaced by the nearest registered frame's (earlier on a tie)."""
    from miketalk.track.video_crops import nearest_tracked

    return nearest_tracked(transforms)


def _check_colour(median: np.ndarray, stabilizer, source: str) -> None:
    """Refuse a registered video whose face's colour the model's mouth cannot match."""
    from miketalk.composite.video_checks import MAX_COLOUR_SHIFT, colour_shift

    shift = colour_shift(median, stabilizer.reference, stabilizer.mask)
    if shift > MAX_COLOUR_SHIFT:
        raise MiketalkError(
            f"{source}: its face's colour is far from the model's (chromaticity {shift:.3f} "
            f"from the reference's, at most {MAX_COLOUR_SHIFT} allowed): give a video in "
            "natural colour and steady light"
        )


def _register(stabilizer, frames: np.ndarray, init: np.ndarray, *, source: str, progress: bool):
    """:meth:`Stabilizer.register` in chunks, each starting from the last registered frame."""
    chunk = 50
    out = np.empty((len(frames), 2, 3))
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(frames), desc="registering", unit="frame")
    start = init
    for i in range(0, len(frames), chunk):
        part = stabilizer.register(frames[i : i + chunk], clip=source, init=start, on_failure="nan")
        out[i : i + chunk] = part
        ok = np.flatnonzero(np.isfinite(part[:, 0, 0]))
        start = part[ok[-1]] if len(ok) else None
        if bar is not None:
            bar.update(len(part))
    if bar is not None:
        bar.close()
    return out
