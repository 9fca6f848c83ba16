"""The lip-sync settings: their closed vocabularies, ranges, defaults and checks, in one home.

Each closed vocabulary is an enum defined here once (:class:`LipsyncModel`,
:class:`Sampling`, :class:`Trajectory`); the command line's choices, the workflow's
config schema and the library take them from here (``tests/test_vocabulary.py``
compares them). :class:`LipsyncSettings` holds one utterance's settings, checked
when made. Standard library only: ``miketalk say`` checks its options before it
starts Festival, and Festival starts before numpy loads.
"""

from __future__ import annotations

import numbers
from collections.abc import Collection
from dataclasses import dataclass
from enum import StrEnum

from miketalk import defaults
from miketalk.errors import MiketalkError, SettingError


class Sampling(StrEnum):
    """How transitions too fast for ``max_px_per_frame`` are sampled
    (:mod:`miketalk.lipsync.sampling`)."""

    BLUR = "blur"  #: the speech keeps its duration; each frame averages its exposure's morphs
    PAPER = "paper"  #: the speech is lengthened until no step is over the limit (paper §7)
    NONE = "none"  #: one morph per frame


class LipsyncModel(StrEnum):
    """How the mouth moves between visemes."""

    #: each transition from one viseme all the way to the next (paper §7)
    PAPER = "paper"
    #: the model's fitted coarticulation (:mod:`miketalk.draw.coarticulation`)
    LEARNED = "learned"
    #: the person's own frames along a trajectory (:mod:`miketalk.draw.trained`)
    TRAINED = "trained"


class Trajectory(StrEnum):
    """The trained face's trajectory models (:mod:`miketalk.draw.trained.trajectory`)."""

    WINDOW = "window"  #: a ridge over the phone context
    REGULARIZED = "regularized"  #: MMM's per-phone targets
    HEARD = "heard"  #: the phones and the recording (a recording only)
    #: the person-independent model, adapted to the face (a recording only;
    #: :mod:`miketalk.draw.trained.pooled`)
    POOLED = "pooled"


#: The vocabularies' values, in their order, as plain strings (command-line choices).
SAMPLINGS: tuple[str, ...] = tuple(s.value for s in Sampling)
LIPSYNC_MODELS: tuple[str, ...] = tuple(m.value for m in LipsyncModel)
TRAJECTORIES: tuple[str, ...] = tuple(t.value for t in Trajectory)

#: The lip-sync model an utterance uses when none is asked for: the first of these the model
#: has, for typed text and for a recording (:func:`resolve_lipsync_model`). On s1's 40
#: held-out bench clips (docs/results.md), typed text through ``learned`` follows his lip
#: opening better (r 0.641) than through ``trained`` from the phones alone (0.622) or
#: ``paper`` (0.602); his recording through ``trained``, which hears it, best of all (0.698,
#: and the least mouth LMD). A synthetic face's model has only ``paper``.
PREFERRED_LIPSYNC_MODELS: dict[str, tuple[LipsyncModel, ...]] = {
    "text": (LipsyncModel.LEARNED, LipsyncModel.TRAINED, LipsyncModel.PAPER),
    "recording": (LipsyncModel.TRAINED, LipsyncModel.LEARNED, LipsyncModel.PAPER),
}

#: The frame rates ``say`` accepts, frames per second (inclusive).
FPS_RANGE = (1.0, 240.0)
#: The ``max_px_per_frame`` values ``say`` accepts, pixels (inclusive). Below half a
#: pixel the blur renders hundreds of morphs per frame and the paper's mode
#: lengthens speech tenfold and more, for no visible gain.
MAX_PX_RANGE = (0.5, 100.0)


def check_fps(fps: object) -> float:
    """``fps`` as a float, checked to lie in :data:`FPS_RANGE`.

    Raises
    ------
    MiketalkError
        Naming the range, for anything else (NaN and infinities included).
    """
    return _in_range(fps, "fps", FPS_RANGE, "frames per second")


def check_max_px(max_px_per_frame: object) -> float:
    """``max_px_per_frame`` as a float, checked to lie in :data:`MAX_PX_RANGE`."""
    return _in_range(max_px_per_frame, "max_px_per_frame", MAX_PX_RANGE, "pixels")


def check_sampling(sampling: object) -> Sampling:
    """``sampling`` checked to be one of :data:`SAMPLINGS`."""
    if sampling not in SAMPLINGS:
        raise SettingError(f"{{sampling}} must be one of {', '.join(SAMPLINGS)}, not {sampling!r}")
    return Sampling(sampling)


def check_lipsync_model(lipsync_model: object) -> LipsyncModel:
    """``lipsync_model`` checked to be one of :data:`LIPSYNC_MODELS`."""
    if lipsync_model not in LIPSYNC_MODELS:
        raise MiketalkError(
            f"lipsync model must be one of {', '.join(LIPSYNC_MODELS)}, not {lipsync_model!r}"
        )
    return LipsyncModel(lipsync_model)


def check_trajectory_name(trajectory: object) -> Trajectory | None:
    """``trajectory`` (None: the face's own) checked to be one of :data:`TRAJECTORIES`."""
    if trajectory is None:
        return None
    if trajectory not in TRAJECTORIES:
        raise MiketalkError(
            f"trajectory model must be one of {', '.join(TRAJECTORIES)}, not {trajectory!r}"
        )
    return Trajectory(trajectory)


def check_max_slowdown(max_slowdown: object) -> float | None:
    """``max_slowdown`` (None: no cap) checked to be a finite number of at least 1."""
    if max_slowdown is None:
        return None
    if isinstance(max_slowdown, bool) or not isinstance(max_slowdown, numbers.Real):
        raise SettingError(f"{{max_slowdown}} must be a number of at least 1, not {max_slowdown!r}")
    value = float(max_slowdown)
    if not 1.0 <= value < float("inf"):  # also NaN
        raise SettingError(
            f"{{max_slowdown}} must be a finite number of at least 1 (1: the speech's own "
            f"duration), not {value:g}"
        )
    return value


def _in_range(value: object, name: str, bounds: tuple[float, float], unit: str) -> float:
    lo, hi = bounds
    message = f"{{{name}}} must be a number from {lo:g} to {hi:g} {unit}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SettingError(f"{message}, not {value!r}")
    number = float(value)
    if not lo <= number <= hi:  # also NaN
        raise SettingError(f"{message}, not {number:g}")
    return number


def check_trajectory(trajectory: str | None, *, lipsync_model: str, recorded: bool) -> None:
    """A trajectory model asked for goes with the trained face, and ``heard`` with a recording
    (``recorded``); which models a face has is :meth:`~miketalk.draw.trained.TrainedFace.kind_for`'s
    check.

    Raises
    ------
    SettingError
        In one line, naming the settings.
    """
    if trajectory is None:
        return
    if lipsync_model != "trained":
        raise _not_trained()
    if trajectory in ("heard", "pooled") and not recorded:
        raise SettingError(
            f"the {trajectory} trajectory ({{trajectory}} {trajectory}) listens to a recording: "
            "give one ({audio}), or use window or regularized with typed text"
        )


def _not_trained() -> SettingError:
    """A trajectory asked for with another lip-sync model than ``trained``."""
    return SettingError("{trajectory} goes with {lipsync_model} trained")


def check_sampling_rules(sampling: Sampling, max_slowdown: float | None) -> None:
    """``max_slowdown`` goes with the paper's sampling, the only one that lengthens speech.

    Raises
    ------
    SettingError
        Naming both settings.
    """
    if max_slowdown is not None and sampling != Sampling.PAPER:
        raise SettingError(
            "{max_slowdown} caps how much {sampling} paper lengthens the speech; "
            f"{{sampling}} {Sampling(sampling).value} keeps the speech's own duration"
        )


def resolve_lipsync_model(
    requested: str | None,
    *,
    available: Collection[str],
    trajectory: str | None = None,
    recorded: bool,
) -> LipsyncModel:
    """The lip-sync model an utterance is drawn with: ``requested``, else ``trained`` when a
    ``trajectory`` is asked for, else the first of :data:`PREFERRED_LIPSYNC_MODELS` (for a
    recording with ``recorded``, else for typed text) among those the model has
    (``available``: :func:`miketalk.model.parts.lipsync_models_in`, or what a workflow's face
    will have). The trajectory and the model are then checked together
    (:func:`check_trajectory`).

    Raises
    ------
    MiketalkError
        In one line: an unknown model or trajectory, a trajectory without ``trained``, the
        heard trajectory without a recording. Whether the model has a ``requested`` model is
        for what draws it to say (:func:`miketalk.draw.registry.open_drawing`).
    """
    trajectory = check_trajectory_name(trajectory)
    if requested is None:
        if trajectory is not None:
            model = LipsyncModel.TRAINED
        else:
            choices = PREFERRED_LIPSYNC_MODELS["recording" if recorded else "text"]
            model = next(name for name in choices if name in available)
    else:
        model = check_lipsync_model(requested)
    check_trajectory(trajectory, lipsync_model=model, recorded=recorded)
    return model


@dataclass(frozen=True)
class LipsyncSettings:
    """One utterance's lip-sync settings, checked when made.

    Attributes
    ----------
    fps : float
        Frame rate, in :data:`FPS_RANGE`.
    max_px_per_frame : float or None
        The largest step between consecutive morphs, in :data:`MAX_PX_RANGE`; None: no limit
        (as ``sampling="none"``).
    sampling : Sampling
        How transitions too fast for the limit are sampled.
    max_slowdown : float or None
        With ``sampling="paper"``: the speech may become at most this many times longer
        than the engine's own timing. None: no cap, as in the paper.
    model : LipsyncModel or None
        How the mouth moves; None: the model's own (:func:`resolve_lipsync_model`).
    trajectory : Trajectory or None
        With ``trained``: its trajectory model; None: ``heard`` for a recording when the
        face has it, else the face's default.
    """

    fps: float = defaults.FPS
    max_px_per_frame: float | None = defaults.MAX_PX_PER_FRAME
    sampling: Sampling = Sampling.BLUR
    max_slowdown: float | None = None
    model: LipsyncModel | None = None
    trajectory: Trajectory | None = None

    def __post_init__(self) -> None:
        check_fps(self.fps)
        if self.max_px_per_frame is not None:
            check_max_px(self.max_px_per_frame)
        object.__setattr__(self, "sampling", check_sampling(self.sampling))
        check_max_slowdown(self.max_slowdown)
        check_sampling_rules(self.sampling, self.max_slowdown)
        if self.model is not None:
            object.__setattr__(self, "model", check_lipsync_model(self.model))
        object.__setattr__(self, "trajectory", check_trajectory_name(self.trajectory))
        if self.trajectory is not None and self.model not in (None, LipsyncModel.TRAINED):
            raise _not_trained()
