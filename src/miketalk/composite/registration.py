"""A video's frames registered to a model's reference, and checked to show its person.

:func:`register_video` registers frames of the reference's size (a video's frames scaled
to it, or its face crops, :mod:`miketalk.track`) with the model's stabilizer: the first
usable frame alone first (a video whose first frame does not register does not show the
model's person), then all of them in chunks, each starting from the last registered
frame; frames that do not register take the nearest registered frame's transform, and
the transforms are smoothed in time. It finds the blinks (:mod:`~miketalk.composite.blinks`)
and the light (the median of the registered frames), and refuses a video whose mouth and
chin do not land on the model's, or whose face's colour the model's mouth cannot match. It
reads the frames in order, twice (to register them, then to stabilize them for the blinks and
the light), and holds a chunk of them and an evenly spread sample: frames made again at each
reading (:class:`~miketalk.track.video_crops.StreamedCrops`) keep its memory independent of the
video's length.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import islice

import numpy as np

from miketalk import defaults
from miketalk.composite.blinks import (  # the blinks: the eye bands of the registered frames
    BLINK_FACTOR,
    _blinks_of_changes,
    _eye_sums,
    _EyeChanges,
    eye_band,
    find_blinks,
)
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
    frames : numpy.ndarray or re-iterable
        ``(N, h, w, 3)`` uint8 RGB at the reference's size (a video's frames scaled to
        it, or its face crops): an array, or frames made again at each reading (``len()``
        and iteration, :class:`~miketalk.track.video_crops.StreamedCrops`).
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

    first_frame = _frame(frames, start)
    first = stabilizer.register(first_frame[None], clip=source, on_failure="nan")
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
    peaks = [] if refine else face_matches(first_frame, stabilizer, first[0])
    if len(peaks) > 1 and peaks[1] >= SECOND_FACE:
        raise MiketalkError(
            f"{source}: its first frame shows the model's face twice (a second place matches "
            f"it at {peaks[1]:.2f}, at least {SECOND_FACE} counts): give a video of one person"
        )
    some = _spread(len(frames), _SAMPLE)  # the field and the light from at most _SAMPLE frames
    transforms, sample = _register(
        stabilizer, frames, first[0], source=source, progress=progress, keep=some
    )
    if refine:
        transforms = refine_crops(transforms, usable, stabilizer)[0]
    transforms[~usable] = np.nan
    ok = np.isfinite(transforms[:, 0, 0])
    if ok.mean() < 0.5:
        raise MiketalkError(
            f"{source}: only {int(ok.sum())} of its {len(ok)} frames show the model's person "
            "(register to its reference): give a frontal video of the same person"
        )
    field = stabilizer.conform(sample, transforms[some], clip=source)
    transforms = _fill(transforms)
    if smooth > 0 and len(transforms) > 1:
        transforms = smooth_in_time(transforms, smooth * fps)
    picked = {}  # each shot's frames its light is measured on
    if shots is not None:
        for shot in np.unique(shots[shots >= 0]):
            frames_of = np.flatnonzero(shots == shot)
            picked[int(shot)] = frames_of[_spread(len(frames_of), _SAMPLE)]
    changes, medians = _stabilized(stabilizer, frames, transforms, field, {-1: some, **picked})
    blinks = _blinks_of_changes(changes)
    median = medians.pop(-1)
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
    # each shot's own light (the addresses' differ from shot to shot)
    by_shot = medians if shots is not None else None
    return Registration(transforms, field, blinks, median, by_shot)


#: Frames stabilized at a time: only their eye band and the frames the light is measured on
#: are kept, so memory does not grow with the video's length (a stabilized copy of every
#: frame did).
_CHUNK = 50


def _stabilized(
    stabilizer, frames, transforms, field, picked: dict[int, np.ndarray]
) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """Every frame's eye change (:class:`_EyeChanges`), and for each key of ``picked`` the
    median of its frames (sorted indices) stabilized; the frames stabilized :data:`_CHUNK` at
    a time, each set's frames let go once its median is taken (a shot's frames lie within the
    shot), so that what is held is at most a block of eye bands (2 bytes a pixel of the band
    a frame) and two sets' frames."""
    changes, held, medians = _EyeChanges(len(frames)), {key: [] for key in picked}, {}
    for start, chunk in _chunks(frames, _CHUNK):
        part = stabilizer.apply(chunk, transforms[start : start + len(chunk)], field=field)
        changes.add(_eye_sums(part, stabilizer.mouth_box))
        stop = start + len(part)
        for key, at in picked.items():
            if key in medians:
                continue
            held[key].extend(part[at[(at >= start) & (at < stop)] - start])
            if len(at) and at[-1] < stop:  # its last frame read: its median, and let go
                medians[key] = median_frames(np.stack(held.pop(key)))
    return changes.changes(), medians


def median_frames(frames: np.ndarray) -> np.ndarray:
    """``np.median(frames, axis=0).astype(np.uint8)`` of uint8 frames, the same bytes, about
    seven times sooner: each pixel's values sorted along a contiguous axis by numpy's radix
    sort (``kind="stable"`` of 8-bit values), the two middle ones' mean rounded down as the
    float median's cast is (0.5 s to 0.08 s for 100 frames of 256 x 256 x 3)."""
    k = len(frames)
    values = np.ascontiguousarray(np.asarray(frames, np.uint8).reshape(k, -1).T)
    ordered = np.sort(values, axis=1, kind="stable")
    low, high = ordered[:, (k - 1) // 2], ordered[:, k // 2]
    middle = (low.astype(np.uint16) + high) // 2
    return middle.astype(np.uint8).reshape(frames.shape[1:])


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


def _register(
    stabilizer, frames, init: np.ndarray, *, source: str, progress: bool, keep: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Stabilizer.register` in chunks, each starting from the last registered frame;
    with the frames ``keep`` (sorted indices) read on the way."""
    out = np.empty((len(frames), 2, 3))
    kept = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(frames), desc="registering", unit="frame")
    start = init
    for i, chunk in _chunks(frames, 50):
        part = stabilizer.register(chunk, clip=source, init=start, on_failure="nan")
        out[i : i + len(chunk)] = part
        kept.append(chunk[keep[(keep >= i) & (keep < i + len(chunk))] - i])
        ok = np.flatnonzero(np.isfinite(part[:, 0, 0]))
        start = part[ok[-1]] if len(ok) else None
        if bar is not None:
            bar.update(len(part))
    if bar is not None:
        bar.close()
    return out, np.concatenate(kept)


def _chunks(frames, size: int) -> Iterator[tuple[int, np.ndarray]]:
    """``(start, frames[start : start + size])`` in order, over an array (its slices) or one
    reading of frames made again at each reading."""
    if isinstance(frames, np.ndarray):
        for start in range(0, len(frames), size):
            yield start, frames[start : start + size]
        return
    batch: list[np.ndarray] = []
    start = 0
    for frame in frames:
        batch.append(frame)
        if len(batch) == size:
            yield start, np.stack(batch)
            start, batch = start + size, []
    if batch:
        yield start, np.stack(batch)


def _frame(frames, index: int) -> np.ndarray:
    """Frame ``index`` of an array, or of frames made again at each reading (read up to it)."""
    if isinstance(frames, np.ndarray):
        return frames[index]
    reading = iter(frames)
    try:
        return next(islice(reading, index, None))
    finally:
        close = getattr(reading, "close", None)
        if close is not None:
            close()
