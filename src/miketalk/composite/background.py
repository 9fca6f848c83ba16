"""Background sequences: the person's own frames, head motion and blinks, under the mouth.

A model built from clips keeps a few seconds of one training clip, cut where
the head stands still (:func:`miketalk.composite.loop.still_window`), as it was
recorded (:func:`miketalk.building.background.write_background`, in
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
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from miketalk import defaults
from miketalk.composite.loop import pingpong
from miketalk.errors import MiketalkError
from miketalk.media.yuv import I420Frame, even_box, paste_rgb

__all__ = [
    "Background",
    "background_doc",
    "background_from_video",
    "check_video",
    "composited",
    "pingpong",
    "streamed_background",
]


#: The shortest video ``dub`` and ``--background VIDEO`` take, seconds.
MIN_SECONDS = 1.0


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
    shown : numpy.ndarray or None
        (N,) bool: the frames the mouth is put into; the others (a tracked video's
        frames without the face, :mod:`miketalk.composite.tracked`) play as they are.
        None: all of them.
    shot : numpy.ndarray or None
        (N,) int: which run of tracked frames of one shot each frame belongs to (-1 where
        not shown): the loop turns within one (None: all one shot).
    steady_shots : dict of int to numpy.ndarray, or None
        Each shot's own :attr:`steady` (its light): the mouth's colour is matched to the
        shot it is put into (None: to :attr:`steady` everywhere).
    i420 : numpy.ndarray or None
        (N, H * 3 // 2, W) uint8: the same frames in the encoder's colours
        (:mod:`miketalk.media.yuv`; a model's own frames, kept decoded,
        :mod:`miketalk.media.kept_frames`), so that :func:`composited` converts only the
        mouth's box of each. None: only RGB.
    left_out : tuple of str
        The tracker's ranges of frames without one frontal face, as said in a warning
        (:mod:`miketalk.composite.tracked`).

    The frames may be an array or a sequence read when needed
    (:mod:`miketalk.media.frame_source`): indexed by a whole number, with ``shape``.
    """

    frames: np.ndarray
    transforms: np.ndarray
    field: np.ndarray | None
    fps: float
    blinks: tuple[int, ...] = ()
    source: str = ""
    steady: np.ndarray | None = None
    shown: np.ndarray | None = None
    shot: np.ndarray | None = None
    steady_shots: dict[int, np.ndarray] | None = None
    i420: np.ndarray | None = None
    left_out: tuple[str, ...] = ()

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
    i420: bool = False,
    placements: Sequence | None = None,
    start: int = 0,
) -> Iterator[np.ndarray | I420Frame]:
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
        of it and ``background.steady``), or once for each of its shots
        (``background.steady_shots``: a cut to another light), instead of frame by
        frame.
    i420 : bool
        Yield :class:`~miketalk.media.yuv.I420Frame` frames when the background has its
        frames in the encoder's colours (:attr:`Background.i420`): each a copy of its
        background frame's with the mouth's box (grown to even corners) converted from the
        blend, what converting the whole blended frame gives. Else (H', W', 3) RGB frames.
    placements : sequence, optional
        Each background frame's :meth:`Compositor.place`, made before (None: made for each
        output frame).
    start : int
        The output frame the first render is (a sentence after others: the background
        goes on from there).
    """
    offset = None
    if rest is not None and background.steady is not None:
        offset = compositor.colour_field(rest, background.steady)
    by_shot: dict[int, np.ndarray] = {}
    planes = background.i420 if i420 else None
    for k, render in enumerate(renders, start):
        i = background.index(k, fps)
        if background.shown is not None and not background.shown[i]:
            if planes is not None:
                yield I420Frame(np.array(planes[i], np.uint8, copy=True))
            else:
                yield np.array(background.frames[i], np.uint8, copy=True)
            continue
        here = offset
        shot = -1 if background.shot is None else int(background.shot[i])
        if offset is not None and shot in (background.steady_shots or {}):
            if shot not in by_shot:
                by_shot[shot] = compositor.colour_field(rest, background.steady_shots[shot])
            here = by_shot[shot]
        frame, transform = background.frames[i], background.transforms[i]
        blended = compositor.blend_box(
            frame, render, transform, field=background.field, offset=here,
            placement=None if placements is None else placements[i],
        )  # fmt: skip
        if planes is None:
            out = np.array(frame, np.uint8, copy=True)
            if blended is not None:
                (x0, y0, x1, y1), pixels = blended
                out[y0:y1, x0:x1] = pixels
            yield out
            continue
        out = np.array(planes[i], np.uint8, copy=True)
        if blended is not None:
            box, pixels = blended
            even = even_box(box, background.size)
            if even != box:  # the box's own pixels beside it, to convert 2x2 blocks whole
                region = np.array(frame[even[1] : even[3], even[0] : even[2]], np.uint8)
                region[box[1] - even[1] : box[3] - even[1],
                       box[0] - even[0] : box[2] - even[0]] = pixels  # fmt: skip
                pixels = region
            paste_rgb(out, even, pixels)
        yield I420Frame(out)


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


def check_video(path: str | os.PathLike[str]) -> tuple[np.ndarray, float]:
    """Read a video of the person, refusing one shorter than :data:`MIN_SECONDS`.

    Raises
    ------
    MiketalkError
        Missing, unreadable, without video, or too short (one line each).
    """
    from miketalk.media.decode import read_video

    frames, fps = read_video(path)
    _check_length(path, len(frames), fps)
    return frames, fps


def _check_length(path: str | os.PathLike[str], n: int, fps: float) -> None:
    """Refuse a video of ``n`` frames at ``fps`` shorter than :data:`MIN_SECONDS`."""
    if n / fps < MIN_SECONDS:
        raise MiketalkError(
            f"{path} lasts {n / fps:.2f} s ({n} frames at {fps:g} fps): "
            f"a video to play under the mouth must last at least {MIN_SECONDS:g} s"
        )


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
        The model's (:meth:`miketalk.model.face.Model.stabilizer`).
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
        As :func:`register_video`: the video does not show the model's person frontally.
    """
    fit = _to_reference(frames.shape[1:3], stabilizer)
    small = frames if fit is None else np.stack([fit(f) for f in frames])
    return _registered(small, frames, fps, stabilizer, source, progress, smooth)


def streamed_background(
    path: str | os.PathLike[str],
    stabilizer,
    *,
    source: str | None = None,
    progress: bool = False,
    smooth: float = defaults.BACKGROUND_SMOOTH,
) -> Background:
    """:func:`background_from_video` of a video file, its frames streamed, never all held.

    The video's frames are counted (decoded in grey), then decoded twice more, each frame
    scaled to the reference's size as it comes, for the registration's two readings
    (:class:`_Fitted`); the frames at their own size are decoded again as the output is
    written (:class:`~miketalk.media.frame_source.VideoFrames`), so memory grows neither
    with the video's pixels nor with its length (before: the whole video at its own size,
    twice, and scaled: 3 s of 1080p 1.49 GB, 9 s 4.23 GB; then its frames at the
    reference's size, 0.3 MB a frame of s1's 360x288).

    Raises
    ------
    MiketalkError
        As :func:`check_video` and :func:`background_from_video`.
    """
    from miketalk.media.decode import iter_video_frames, video_info
    from miketalk.media.frame_source import VideoFrames

    source = source or str(path)
    width, height, fps = video_info(path)
    count = sum(1 for _ in iter_video_frames(path, grey=True))
    _check_length(path, count, fps)
    video = VideoFrames(path, count=count, fps=fps)
    small = _Fitted(path, _to_reference((height, width), stabilizer), count)
    return _registered(small, video, fps, stabilizer, source, progress, smooth)


class _Fitted:
    """A video's ``count`` frames scaled to the reference's size (``fit``; None: as they
    are), made again at each reading: ``len()`` and iteration, as registration reads them."""

    def __init__(self, path: str | os.PathLike[str], fit, count: int) -> None:
        self.path, self.fit, self.count = path, fit, count

    def __len__(self) -> int:
        return self.count

    def __iter__(self) -> Iterator[np.ndarray]:
        from miketalk.media.decode import iter_video_frames

        frames, k = iter_video_frames(self.path, frames=self.count), 0
        try:
            for frame in frames:
                yield frame if self.fit is None else self.fit(frame)
                k += 1
        finally:
            frames.close()
        if k < self.count:
            raise MiketalkError(
                f"{self.path} gave {k} frames on a later reading, {self.count} on its first"
            )


def _to_reference(size: tuple[int, int], stabilizer):
    """The function scaling a frame of ``size`` ``(H, W)`` to the reference's (None: same)."""
    import cv2

    h, w = stabilizer.mask.shape
    if tuple(size) == (h, w):
        return None
    return lambda frame: cv2.resize(frame, (w, h), interpolation=cv2.INTER_AREA)


def _registered(small, frames, fps, stabilizer, source, progress, smooth) -> Background:
    """The frames ``small`` (at the reference's size) registered; ``frames`` kept to play."""
    h, w = stabilizer.mask.shape
    fh, fw = frames.shape[1:3]
    scale = np.diag([fw / w, fh / h, 1.0])
    scaled = ""
    if abs(fw * h / (fh * w) - 1) > 0.02:
        scaled = (
            f"; it is {fw}x{fh}, the reference {w}x{h}, and frames are scaled to the "
            "reference's size: another shape distorts the face"
        )
    from miketalk.composite.registration import register_video

    found = register_video(
        small, fps, stabilizer, source=source, progress=progress, smooth=smooth, scaled=scaled
    )
    full = np.array([(scale @ np.vstack([t, [0, 0, 1]]))[:2] for t in found.transforms])
    return Background(frames, full, found.field, float(fps), found.blinks, source, found.steady)
