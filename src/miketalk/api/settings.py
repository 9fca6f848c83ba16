"""The settings of each use case: one typed object each, its defaults and rules here alone.

:class:`SaySettings` (``say``: a text or a recording to an mp4), :class:`DubSettings` (``dub``:
a video of the model's person saying new speech), :class:`BuildSettings` (``build``: a model
from one video) and :class:`CuesSettings` (``cues``: a text's or a recording's mouth cues) are
checked when made; a setting that does not fit is one :class:`~miketalk.errors.SettingError`
naming the settings as spelled here, which the command line names by its flags and the page
by its form fields. The workflow's config schema is tested against the same defaults
(``tests/test_vocabulary.py``). Standard library only: ``miketalk say`` checks its settings
before it starts Festival, and Festival starts before numpy loads.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from miketalk import defaults
from miketalk.building.frame import DEFAULT_FRAME, FrameSettings
from miketalk.errors import SettingError
from miketalk.lipsync.settings import (
    LipsyncModel,
    LipsyncSettings,
    Sampling,
    Trajectory,
    check_fps,
    check_lipsync_model,
    check_max_px,
    check_max_slowdown,
    check_sampling,
    check_trajectory_name,
)
from miketalk.speech.festival.voices import VOICES

__all__ = ["BuildSettings", "CuesSettings", "DubSettings", "SaySettings", "SpeechSettings"]

Path = str | os.PathLike[str]


@dataclass(frozen=True)
class SpeechSettings:
    """What ``say`` and ``dub`` share: the model, how its mouth moves, the voice.

    Attributes
    ----------
    model : path-like or None
        The model's directory (None: ``$MIKETALK_MODEL``, else the synthetic face ``make run``
        builds, :func:`miketalk.model.parts.default_model_dir`).
    lipsync_model : LipsyncModel or None
        How the mouth moves (None: the model's own for typed text or for a recording,
        :func:`miketalk.lipsync.settings.resolve_lipsync_model`).
    trajectory : Trajectory or None
        With ``trained``: its trajectory model (None: ``heard`` for a recording when the face
        has it, else the face's own).
    sampling : Sampling
        How transitions too fast for ``max_px_per_frame`` are drawn.
    max_px_per_frame : float or None
        The largest step between morphs, pixels (None: :data:`miketalk.defaults.
        MAX_PX_PER_FRAME`, or no limit with ``sampling`` none, which takes no step limit).
    voice : str or None
        Festival's voice for typed text (None: kal); a recording speaks with its own.
    overwrite : bool
        Replace an mp4 or timeline JSON miketalk did not write (never an input).
    check_person : bool
        Refuse a video (a dub's, or a background) that does not show the model's person
        (:mod:`miketalk.track.identity`).
    """

    model: Path | None = None
    lipsync_model: LipsyncModel | None = None
    trajectory: Trajectory | None = None
    sampling: Sampling = Sampling.BLUR
    max_px_per_frame: float | None = None
    voice: str | None = None
    overwrite: bool = False
    check_person: bool = True

    def __post_init__(self) -> None:
        if self.lipsync_model is not None:
            object.__setattr__(self, "lipsync_model", check_lipsync_model(self.lipsync_model))
        object.__setattr__(self, "trajectory", check_trajectory_name(self.trajectory))
        object.__setattr__(self, "sampling", check_sampling(self.sampling))
        if self.max_px_per_frame is not None:
            object.__setattr__(self, "max_px_per_frame", check_max_px(self.max_px_per_frame))
            if self.sampling == Sampling.NONE:
                raise SettingError("{max_px_per_frame} has no effect with {sampling} none")
        if self.voice is not None and self.voice not in VOICES:
            raise SettingError(f"{{voice}} must be one of {', '.join(VOICES)}, not {self.voice!r}")
        self.lipsync(defaults.FPS, self.lipsync_model)  # the lip-sync rules, checked now

    @property
    def step_limit(self) -> float | None:
        """The step limit the drawing keeps (None: none, with ``sampling`` none)."""
        if self.sampling == Sampling.NONE:
            return None
        return defaults.MAX_PX_PER_FRAME if self.max_px_per_frame is None else self.max_px_per_frame

    def lipsync(self, fps: float, lipsync_model: LipsyncModel | None) -> LipsyncSettings:
        """The engine's settings at frame rate ``fps``, drawn with ``lipsync_model`` (chosen
        for the model, :func:`miketalk.draw.registry.choose_lipsync_model`)."""
        return LipsyncSettings(
            fps=fps,
            max_px_per_frame=self.step_limit,
            sampling=self.sampling,
            max_slowdown=getattr(self, "max_slowdown", None),
            model=lipsync_model,
            trajectory=self.trajectory,
        )


@dataclass(frozen=True)
class SaySettings(SpeechSettings):
    """``say``'s settings: :class:`SpeechSettings` and the following.

    Attributes
    ----------
    fps : float or None
        Frame rate (None: the background video's own for a model that works in a face crop,
        its head motion frame for frame; else :data:`miketalk.defaults.FPS`).
    max_slowdown : float or None
        With ``sampling`` paper: the speech may become at most this many times longer than
        the voice's own timing (None: no cap, as in the paper).
    background : str or None
        ``auto`` (the model's own video of the person if it keeps one, else its still face),
        ``still``, or a video of the model's person (None: ``auto``).
    grouping : dict or None
        Corpus targets shown as another viseme than the paper's
        (:class:`~miketalk.visemes.VisemeTable`'s ``grouping``: the workflow's
        ``visemes.grouping``; None: the paper's 16 visemes).
    """

    fps: float | None = None
    max_slowdown: float | None = None
    background: str | None = None
    grouping: dict | None = None

    def table(self):
        """The phone-to-viseme table (None: the paper's, :func:`miketalk.visemes.default_table`)."""
        if not self.grouping:
            return None
        from miketalk.visemes import VisemeTable

        return VisemeTable(grouping=self.grouping)

    def __post_init__(self) -> None:
        if self.fps is not None:
            object.__setattr__(self, "fps", check_fps(self.fps))
        object.__setattr__(self, "max_slowdown", check_max_slowdown(self.max_slowdown))
        super().__post_init__()  # with max_slowdown's rule, LipsyncSettings'


@dataclass(frozen=True)
class DubSettings(SpeechSettings):
    """``dub``'s settings: :class:`SpeechSettings`; the frame rate is the video's own, and the
    speech cannot be lengthened (the video plays at its own pace), so ``sampling`` is blur
    or none."""

    def __post_init__(self) -> None:
        if check_sampling(self.sampling) == Sampling.PAPER:
            raise SettingError(
                "{sampling} paper lengthens the speech, and a dub plays the video at its own "
                "pace: use blur (the default) or none"
            )
        super().__post_init__()


@dataclass(frozen=True)
class BuildSettings:
    """``build``'s settings.

    Attributes
    ----------
    frame : str
        ``crop`` (the default, :data:`~miketalk.building.frame.DEFAULT_FRAME`, the
        workflow's too: the face tracked and the model made in its fixed-size crop, the
        output at the video's own resolution; any video of one person) or ``full`` (the
        video's own pixels: a still head before a plain backdrop).
    crop_size : int or None
        With ``crop``: the crop's width and height, pixels (None: 256).
    crop_conversion : str or None
        With ``crop``: ffmpeg's YUV-to-RGB conversion of its pixels (None: auto).
    heldout_seconds : float
        The video's last seconds left out of the model.
    workers : int or None
        Processes (None: 2, or 1 on one core).
    keep_corpus : path-like or None
        Keep the corpus folder (stabilized frames, phones) there, for a held-out test.
    overwrite : bool
        Replace an existing model.
    flow : dict or None
        The flow method's ``estimator`` and ``settings`` (None: the workflow's default).
    mixed_window : int
        How many frames the mixed flow strategy searches for its intermediate frame.
    """

    frame: str = DEFAULT_FRAME
    crop_size: int | None = None
    crop_conversion: str | None = None
    heldout_seconds: float = defaults.HELDOUT_SECONDS
    workers: int | None = None
    keep_corpus: Path | None = None
    overwrite: bool = False
    flow: dict | None = None
    mixed_window: int = defaults.BUILD_MIXED_WINDOW

    def __post_init__(self) -> None:
        self.frame_settings  # noqa: B018 (the frame's rules: building.frame's, checked now)

    @property
    def frame_settings(self) -> FrameSettings:
        """The frame the face is built in."""
        return FrameSettings(self.frame, self.crop_size, self.crop_conversion)


@dataclass(frozen=True)
class CuesSettings:
    """``cues``' settings.

    Attributes
    ----------
    extended_shapes : str
        Rhubarb's extended mouth shapes to use, a subset of ``GHX`` (its default).
    voice : str or None
        Festival's voice for typed text (None: kal).
    overwrite : bool
        Replace files miketalk did not write (never an input).
    """

    extended_shapes: str = "GHX"
    voice: str | None = None
    overwrite: bool = False

    def __post_init__(self) -> None:
        from miketalk.lipsync.cues import check_extended

        object.__setattr__(self, "extended_shapes", check_extended(self.extended_shapes))
        if self.voice is not None and self.voice not in VOICES:
            raise SettingError(f"{{voice}} must be one of {', '.join(VOICES)}, not {self.voice!r}")


def check_recorded_speech(settings: SpeechSettings | CuesSettings) -> None:
    """The settings that are Festival's, refused for a recording (it speaks with its own voice
    and keeps its own timing)."""
    if settings.voice is not None:
        raise SettingError("{voice} picks Festival's voice; with {audio} the recording speaks")
    if getattr(settings, "sampling", None) == Sampling.PAPER or (
        getattr(settings, "max_slowdown", None) is not None
    ):
        raise SettingError(
            "{audio} keeps the recording's own timing, so {sampling} paper (which lengthens "
            "the speech) cannot apply: use {sampling} blur (the default) or none"
        )
