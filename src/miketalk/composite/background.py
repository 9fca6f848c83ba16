"""Background sequences: the person's own frames, head motion and blinks, under the mouth.

A model built from clips keeps a few seconds of one training clip, cut where
the head stands still (:func:`miketalk.composite.loop.still_window`), as it was
recorded (:func:`miketalk.composite.background_files.write_background`, in
``<model>/background/``): the frames,
each frame's stabilization transform and the clip's conform field
(:mod:`miketalk.stabilize`), where the eyes blink, and what is needed
to stabilize other video of the same person (the reference frame, the face
mask and the mouth box). :func:`composited` plays such a sequence under the
synthesized mouth (:class:`miketalk.composite.compositor.Compositor`): output
frame ``k`` at ``k / fps`` shows the background frame of that time, the
sequence played forwards, then backwards, then forwards again (ping-pong), so
an utterance longer than the background loops without a jump: a
frame is always followed by one of its neighbours.

:func:`background_from_video` makes the same from any video of the person
(``say --background VIDEO`` and ``miketalk dub``): every frame registered to
the model's reference; frames that do not register (a hand over the face, a
cut) take the nearest registered frame's transform, and the transforms are
smoothed in time (each frame's registration error would slide the mouth
against the nose); a video in which no frame registers does not show the
model's person, and is refused in one line, as is one whose first frame shows
the face twice or whose colour is far from the model's
(:mod:`miketalk.composite.video_checks`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from miketalk import defaults
from miketalk.composite.loop import pingpong, smooth_in_time
from miketalk.errors import MiketalkError

__all__ = [
    "Background",
    "background_doc",
    "background_from_video",
    "check_video",
    "composited",
    "find_blinks",
    "pingpong",
]


#: The shortest video ``dub`` and ``--background VIDEO`` take, seconds.
MIN_SECONDS = 1.0

#: The least correlation of a video's lower face (stabilized, the median over its frames)
#: with the model's reference: the 16 committed GRID clips checked score 0.63 to 0.96, the
#: same man mirrored (registered wrongly, at ECC correlation 0.91) 0.12.
MIN_LOWER_FACE = 0.4

#: A frame blinks when its eye band differs from the sequence's median by this many
#: times the band's median difference (and at least 3 grey levels).
BLINK_FACTOR = 3.0


@dataclass(frozen=True)
class Background:
    """Frames of the person with their stabilization.

    Attributes
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8 RGB as recorded.
    transforms : numpy.ndarray
        (N, 2, 3): reference pixel ``p`` shows in frame ``i`` at
        ``transforms[i] @ (p + field(p), 1)``.
    field : numpy.ndarray or None
        (h, w, 2) float32 conform field in the reference's coordinates.
    fps : float
        The frames' rate.
    blinks : tuple of int
        Frames where the eyes are closed or closing.
    source : str
        Where the frames come from (a clip id or a path).
    steady : numpy.ndarray or None
        (h, w, 3) uint8 the median of the frames stabilized onto the
        reference: the background's light, to match the mouth's colour to.
    """

    frames: np.ndarray
    transforms: np.ndarray
    field: np.ndarray | None
    fps: float
    blinks: tuple[int, ...] = ()
    source: str = ""
    steady: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def size(self) -> tuple[int, int]:
        """``(H, W)`` of the frames."""
        return int(self.frames.shape[1]), int(self.frames.shape[2])

    def index(self, k: int, fps: float) -> int:
        """The background frame shown at output frame ``k`` of a video at ``fps``."""
        return pingpong(round(k * self.fps / fps), len(self))


def composited(
    renders: Iterable[np.ndarray],
    background: Background,
    compositor,
    *,
    fps: float,
    rest: np.ndarray | None = None,
) -> Iterator[np.ndarray]:
    """Each render (reference coordinates) blended into its background frame.

    Parameters
    ----------
    renders : iterable of numpy.ndarray
        The model's frames, (H, W, 3) uint8, output frame ``k`` at ``k / fps``.
    background : Background
    compositor : miketalk.composite.compositor.Compositor
    fps : float
        The output's frame rate.
    rest : numpy.ndarray, optional
        (H, W, 3) the model's silence image: the mouth's colour is then
        matched once for the whole background (:meth:`Compositor.colour_field`
        of it and ``background.steady``) instead of frame by frame.
    """
    offset = None
    if rest is not None and background.steady is not None:
        offset = compositor.colour_field(rest, background.steady)
    for k, render in enumerate(renders):
        i = background.index(k, fps)
        yield compositor(
            background.frames[i],
            render,
            background.transforms[i],
            field=background.field,
            offset=offset,
        )


def background_doc(background: Background | None) -> dict:
    """What the timeline JSON records of a background (nothing for a still face)."""
    if background is None:
        return {}
    return {
        "background": {
            "source": background.source,
            "frames": len(background),
            "fps": background.fps,
            "size": list(background.size),
            "blinks": list(background.blinks),
            "loop": "pingpong",
        }
    }


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
    x, y, w, _ = mouth_box
    top, bottom = max(0, y - round(1.4 * w)), max(1, y - round(0.8 * w))
    left, right = max(0, round(x + w / 2 - 1.2 * w)), round(x + w / 2 + 1.2 * w)
    band = stabilized[:, top:bottom, left:right].astype(np.float32).mean(axis=3)
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
    ok = np.flatnonzero(np.isfinite(transforms[:, 0, 0]))
    idx = np.arange(len(transforms))
    pos = np.clip(np.searchsorted(ok, idx), 1, len(ok) - 1) if len(ok) > 1 else np.zeros_like(idx)
    if len(ok) > 1:
        left, right = ok[pos - 1], ok[pos]
        nearest = np.where(idx - left <= right - idx, left, right)
    else:
        nearest = np.full_like(idx, ok[0])
    return transforms[nearest]


def check_video(path: str | os.PathLike[str]) -> tuple[np.ndarray, float]:
    """Read a video of the person, refusing one shorter than :data:`MIN_SECONDS`.

    Raises
    ------
    MiketalkError
        Missing, unreadable, without video, or too short (one line each).
    """
    from miketalk.media.decode import read_video

    frames, fps = read_video(path)
    if len(frames) / fps < MIN_SECONDS:
        raise MiketalkError(
            f"{path} lasts {len(frames) / fps:.2f} s ({len(frames)} frames at {fps:g} fps): "
            f"a video to play under the mouth must last at least {MIN_SECONDS:g} s"
        )
    return frames, fps


def background_from_video(
    frames: np.ndarray,
    fps: float,
    stabilizer,
    *,
    source: str = "the video",
    progress: bool = False,
    smooth: float = defaults.BACKGROUND_SMOOTH,
) -> Background:
    """Register a video's frames to the model's reference (see the module docstring).

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8 RGB (:func:`check_video`); of another size than the
        reference, the frames are registered scaled to the reference's size
        and the transforms scaled back.
    fps : float
    stabilizer : miketalk.stabilize.Stabilizer
        The model's (:func:`model_stabilizer`).
    source : str
        Named in errors.
    progress : bool
        Draw a progress bar of the registration on stderr.
    smooth : float
        Gaussian sigma in seconds of the transforms smoothed in time
        (:data:`miketalk.defaults.BACKGROUND_SMOOTH`, 0 for none): the registration's
        frame-to-frame error would slide the mouth against the nose.

    Raises
    ------
    MiketalkError
        When the first frame, or fewer than half of all frames, register: the
        video does not show the model's person frontally (or no one).
    """
    import cv2

    h, w = stabilizer.mask.shape
    fh, fw = frames.shape[1:3]
    scale = np.diag([fw / w, fh / h, 1.0])
    small = frames
    if (fh, fw) != (h, w):
        small = np.stack([cv2.resize(f, (w, h), interpolation=cv2.INTER_AREA) for f in frames])
    first = stabilizer.register(small[:1], clip=source, on_failure="nan")
    if not np.isfinite(first).all():
        rho = float(stabilizer.correlations[0])
        why = (
            "no registration to the model's reference converges"
            if rho < 0
            else f"correlation {rho:.2f} with the model's reference, at least "
            f"{stabilizer.min_correlation} needed"
        )
        if abs(fw * h / (fh * w) - 1) > 0.02:
            why += (
                f"; it is {fw}x{fh}, the reference {w}x{h}, and frames are scaled to the "
                "reference's size: another shape distorts the face"
            )
        raise MiketalkError(
            f"{source}: its first frame does not show the model's person ({why}): give a "
            "frontal video of the same person"
        )
    from miketalk.composite.video_checks import SECOND_FACE, face_matches

    peaks = face_matches(small[0], stabilizer, first[0])
    if len(peaks) > 1 and peaks[1] >= SECOND_FACE:
        raise MiketalkError(
            f"{source}: its first frame shows the model's face twice (a second place matches "
            f"it at {peaks[1]:.2f}, at least {SECOND_FACE} counts): give a video of one person"
        )
    transforms = _register(stabilizer, small, first[0], source=source, progress=progress)
    ok = np.isfinite(transforms[:, 0, 0])
    if ok.mean() < 0.5:
        raise MiketalkError(
            f"{source}: only {int(ok.sum())} of its {len(ok)} frames show the model's person "
            "(register to its reference): give a frontal video of the same person"
        )
    some = _spread(len(small), _SAMPLE)  # the field and the light from at most _SAMPLE frames
    field = stabilizer.conform(small[some], transforms[some], clip=source)
    transforms = _fill(transforms)
    if smooth > 0 and len(transforms) > 1:
        transforms = smooth_in_time(transforms, smooth * fps)
    full = np.array([(scale @ np.vstack([t, [0, 0, 1]]))[:2] for t in transforms])
    steady = stabilizer.apply(small, transforms, field=field)
    blinks = find_blinks(steady, stabilizer.mouth_box)
    median = np.median(steady[some], axis=0).astype(np.uint8)
    score = lower_face_correlation(median, stabilizer.reference, stabilizer.mouth_box)
    if score < MIN_LOWER_FACE:
        raise MiketalkError(
            f"{source}: its mouth and chin do not land on the model's (correlation {score:.2f} "
            f"with the model's reference after registration, at least {MIN_LOWER_FACE} needed): "
            "give a frontal video of the same person"
        )
    _check_colour(median, stabilizer, source)
    return Background(frames, full, field, float(fps), blinks, source, median)


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
