"""Where a face from clips (or from one video) is built: in its tracked face crop, or in the
video's own pixels.

``miketalk build --frame crop|full --crop-size PX`` and the workflow's ``faces.NAME.frame``
and ``faces.NAME.crop_size`` are both read into :class:`FrameSettings`, whose
:attr:`~FrameSettings.crop` is what :func:`miketalk.building.stages.corpus_stage` takes.
The rules (a crop size or conversion goes with the crop frame) are checked here alone; the
crop's geometry is :class:`~miketalk.track.crop.FaceCropSettings`'s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from miketalk.errors import SettingError

if TYPE_CHECKING:  # the command line's parser reads FRAMES without the tracker's imports
    from miketalk.track.crop import FaceCropSettings

__all__ = ["CONVERSIONS", "CROP", "DEFAULT_FRAME", "FRAMES", "FULL", "FrameSettings", "own_frame"]

#: Tracked, in the face's canonical crop (:mod:`miketalk.track.crop`).
CROP = "crop"
#: In the video's own pixels (the plain-background rules of :mod:`miketalk.stabilize`).
FULL = "full"
#: The frames a face can be built in.
FRAMES = (CROP, FULL)
#: The frame a face from video of a person is built in unless told, by ``miketalk build``
#: and the workflow alike: the crop, which takes any video of one person (a moving head,
#: any backdrop, any resolution, at the crop's cost per frame); the video's own pixels need
#: a still head before a plain backdrop (GRID's), and the configs that want them say so.
DEFAULT_FRAME = CROP
#: The crop pixels' colour conversions (:attr:`miketalk.track.crop.FaceCropSettings.
#: conversion`'s values, here without its imports for the command line's parser).
CONVERSIONS = ("auto", "fast", "accurate")


@dataclass(frozen=True)
class FrameSettings:
    """The frame a face is built in.

    Attributes
    ----------
    frame : str
        :data:`CROP` or :data:`FULL`.
    crop_size : int or None
        The crop's width and height in pixels, its eye distance in proportion to the
        default crop's (None: :class:`~miketalk.track.crop.FaceCropSettings`' own size);
        only with :data:`CROP`.
    crop_conversion : str or None
        The crop pixels' colour conversion, one of :data:`CONVERSIONS` (None:
        :class:`~miketalk.track.crop.FaceCropSettings`' own); only with :data:`CROP`.
    """

    frame: str
    crop_size: int | None = None
    crop_conversion: str | None = None

    def __post_init__(self) -> None:
        if self.frame not in FRAMES:
            raise SettingError(f"the {{frame}} must be one of {list(FRAMES)}, got {self.frame!r}")
        if self.crop_size is not None and self.frame != CROP:
            raise SettingError("{crop_size} goes with {frame} crop (the face crop's size)")
        if self.crop_conversion is not None and self.frame != CROP:
            raise SettingError("{crop_conversion} goes with {frame} crop (the face crop's pixels)")
        self.crop  # noqa: B018 (a bad size is refused here, not in the corpus stage)

    @property
    def crop(self) -> FaceCropSettings | None:
        """The face crop to build in (None: the video's own pixels)."""
        from miketalk.track.crop import FaceCropSettings

        if self.frame == FULL:
            return None
        default = FaceCropSettings()
        size = default.size if self.crop_size is None else self.crop_size
        return FaceCropSettings(
            size=size,
            eye_distance=default.eye_distance * size / default.size,
            conversion=self.crop_conversion or default.conversion,
        )


def own_frame(frame: str | None, *, of_person: bool) -> str:
    """The frame named (``frame``), else the face's own: :data:`DEFAULT_FRAME` for a face
    from video of a person (``of_person``: clips or one video of any speech, what
    ``miketalk build`` takes), :data:`FULL` for one drawn in its own pixels (the synthetic
    face, a recording of the corpus words)."""
    if frame is not None:
        return frame
    return DEFAULT_FRAME if of_person else FULL
