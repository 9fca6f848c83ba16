"""What composite/ does for a :class:`miketalk.model.face.Model`: the background a ``say`` or
``dub`` plays under its mouth, and its mouth composited into it, each asked of the model
(its background video, crop, tracker reference and mouth box), never read from its folder.

:func:`resolve_background` is ``--background``'s choice (the model's own video, its still
face, or any video of its person registered to its reference by
:func:`video_background`); :func:`model_compositor` is the compositor of its mouth box;
:func:`composite_renders` plays rendered frames into a background.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from enum import StrEnum
from typing import Any

import numpy as np

from miketalk import defaults
from miketalk.composite.background import Background, composited
from miketalk.media.yuv import I420Frame

__all__ = [
    "BACKGROUND_CHOICES",
    "BackgroundChoice",
    "MouthCompositing",
    "composite_renders",
    "model_compositor",
    "resolve_background",
    "video_background",
]


def model_compositor(
    model: Any,
    size: tuple[int, int],
    *,
    skin: bool = defaults.BLEND_SKIN,
    **settings,
):
    """The :class:`~miketalk.composite.compositor.Compositor` of a model built from clips
    (:class:`miketalk.model.face.Model`).

    Its blend mask about the model's mouth box, kept off the reference's backdrop and
    clothes (:func:`~miketalk.composite.compositor.skin_weight` of the reference and its
    face mask, unless ``skin=False``); ``settings`` go to the compositor. A face crop's mask
    is also held inside its jaw ellipse (:func:`~miketalk.track.crop.jaw_mask`), and its jaw's
    warp as :data:`miketalk.defaults.BLEND_FOLLOW_CROP` says (``follow_within`` or ``follow``
    given in ``settings`` win).
    """
    from miketalk.composite.compositor import Compositor, skin_weight

    keep = None
    if skin:
        keep = skin_weight(model.reference, model.face_mask)
    crop = model.crop
    if crop is not None:  # a face crop's: inside the jaw (the frames' jaws turn elsewhere)
        from miketalk.track.crop import jaw_mask

        keep = jaw_mask(crop) if keep is None else keep * jaw_mask(crop)
        if defaults.BLEND_FOLLOW_CROP == "face":  # the jaw's warp off the room beside the jaw
            settings.setdefault("follow_within", keep)
        elif defaults.BLEND_FOLLOW_CROP == "off":
            settings.setdefault("follow", False)
    return Compositor(model.mouth_box, size, keep=keep, **settings)


class BackgroundChoice(StrEnum):
    """What ``--background`` (and a workflow face's ``background``) names, besides a video."""

    AUTO = "auto"  #: the model's own background if it keeps one, else the still face
    STILL = "still"  #: the model's still face


#: The named backgrounds, as plain strings (anything else is a video's path).
BACKGROUND_CHOICES: tuple[str, ...] = tuple(c.value for c in BackgroundChoice)


def resolve_background(
    choice: str | None, model: Any, *, progress: bool = False, check_person: bool = True
):
    """The background of ``--background``: ``auto``, ``still`` or a video's path
    (``check_person``: as :func:`video_background`'s).

    Returns
    -------
    miketalk.composite.background.Background or None
        None for a still face (``still``, or ``auto`` with a model that keeps
        no background: the output is then exactly ``say``'s without one).

    Raises
    ------
    MiketalkError
        A video with a model not built from a person, or a video that cannot
        be read, is shorter than a second, or does not show the model's person.
    """
    choice = choice or defaults.BACKGROUND
    if choice == BackgroundChoice.STILL:
        return None
    if choice == BackgroundChoice.AUTO:
        return model.background() if model.has_background else None
    return video_background(model, choice, progress=progress, check_person=check_person)


def video_background(
    model: Any,
    video: str | os.PathLike[str],
    *,
    progress: bool = False,
    check_person: bool = True,
) -> Background:
    """Any video of the model's person registered to its reference (``say --background
    VIDEO``, ``dub``): through its face crops for a model that works in one
    (:func:`~miketalk.composite.tracked.tracked_background`), else frame by frame
    (:func:`~miketalk.composite.background.background_from_video`).

    Raises
    ------
    MiketalkError
        A model not built from a person, or a video that cannot be read, is shorter
        than a second, or does not show the model's person (refused before it is tracked
        when a first look at a few frames finds no face, :mod:`miketalk.track.first_look`,
        or another person's, :mod:`miketalk.track.identity`, unless ``check_person`` is
        False: ``--force``).
    """
    if model.crop is not None:  # kept from a run before, else made (and kept)
        from miketalk.composite.kept_registration import kept_background

        return kept_background(
            model, video, lambda: _registered(model, video, progress, check_person),
            check_person=check_person,
        )  # fmt: skip
    return _registered(model, video, progress, check_person)


def _registered(model: Any, video, progress: bool, check_person: bool) -> Background:
    """:func:`video_background`, made now."""
    stabilizer = model.stabilizer()
    crop = model.crop
    if crop is not None:
        from miketalk.track.first_look import first_look

        first_look(video, source=str(video))  # no face anywhere: said before tracking it all
    if check_person:
        from miketalk.track.identity import check_person as check

        check(model.reference, video, source=str(video))
    if crop is not None:
        from miketalk.composite.tracked import tracked_background

        return tracked_background(
            video, stabilizer, crop, source=str(video), progress=progress, i420=True,
            halves=True,
        )  # fmt: skip
    from miketalk.composite.background import streamed_background

    return streamed_background(video, stabilizer, source=str(video), progress=progress)


def composite_renders(
    renders: Iterable[np.ndarray],
    background: Background,
    model: Any,
    *,
    fps: float,
    i420: bool = False,
) -> Iterator[np.ndarray | I420Frame]:
    """:func:`composited` with the model's mouth box, size and silence image (``i420``:
    frames in the encoder's colours where the background has them):
    :meth:`MouthCompositing.frames`.

    Parameters
    ----------
    renders : iterable of numpy.ndarray
        The model's frames.
    background : Background
    model : miketalk.model.face.Model
        A model built from clips (:attr:`~miketalk.model.face.Model.has_background`).
    fps : float
        The output's frame rate.
    """
    return MouthCompositing(model, background).frames(renders, fps=fps, i420=i420)


#: A background of at most this many frames keeps each frame's placement (a model's own,
#: a few seconds, played in a loop); a longer one (a dubbed video, each frame played once)
#: has them made again as it plays, so that memory does not grow with its length.
KEEP_PLACEMENTS = 256

#: Pixels beyond a placement's map the compositor's sampling reads (bicubic: two).
SAMPLED_BEYOND = 2


class MouthCompositing:
    """A model's mouth composited into a background: the compositor of its mouth box
    (:func:`model_compositor`), its silence image, and where each background frame puts
    the mouth (:meth:`~miketalk.composite.compositor.Compositor.place`, made once).

    :attr:`region` is ``(x0, y0, x1, y1)``, the renders' pixels compositing reads (every
    placement's map and the interpolation's reach), or None when no frame shows the mouth:
    a drawing may draw that region alone (:meth:`miketalk.draw.registry.Drawing.frames`);
    the output is the same.
    """

    def __init__(self, model: Any, background: Background) -> None:
        from miketalk.visemes import SILENCE

        self.model, self.background = model, background
        self.compositor = model_compositor(model, model.size)
        self.rest = model.image(SILENCE) if SILENCE in model.visemes else None
        h, w = model.size
        low, high = np.array([w, h], np.float64), np.array([-1.0, -1.0])
        kept: list | None = []  # let go past KEEP_PLACEMENTS: memory is not the video's length
        for i in range(len(background)):
            placement = None
            if background.shown is None or background.shown[i]:
                placement = self.compositor.place(
                    background.transforms[i], background.size, field=background.field
                )
            if placement is not None:
                for k, grid in enumerate((placement.map_x, placement.map_y)):
                    low[k], high[k] = min(low[k], grid.min()), max(high[k], grid.max())
            if kept is not None:
                kept.append(placement)
                kept = kept if len(kept) <= KEEP_PLACEMENTS else None
        self.placements = kept
        self.region: tuple[int, int, int, int] | None = None
        if high[0] >= 0:
            # remap rounds a position to 1/32 px: up to one pixel on, then the reach
            x0, y0 = (max(0, int(np.floor(v)) - SAMPLED_BEYOND) for v in low)
            x1 = min(w, int(np.floor(high[0])) + SAMPLED_BEYOND + 2)
            y1 = min(h, int(np.floor(high[1])) + SAMPLED_BEYOND + 2)
            if x1 > x0 and y1 > y0:
                self.region = (x0, y0, x1, y1)

    def frames(
        self, renders: Iterable[np.ndarray], *, fps: float, i420: bool = False, start: int = 0
    ) -> Iterator[np.ndarray | I420Frame]:
        """Each render blended into its background frame (:func:`composited`; ``start``:
        the output frame the first render is)."""
        return composited(
            renders, self.background, self.compositor, fps=fps, rest=self.rest, i420=i420,
            placements=self.placements, start=start,
        )  # fmt: skip
