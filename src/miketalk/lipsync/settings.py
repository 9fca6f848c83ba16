"""The settings of ``say`` and their ranges, checked with the standard library only.

``miketalk say`` checks its options before it starts Festival, and Festival
starts before numpy loads; so these checks live apart from
:mod:`miketalk.lipsync.timeline`, which re-exports them.
"""

from __future__ import annotations

import numbers
from typing import Literal, get_args

from miketalk.errors import MiketalkError

#: How transitions too fast for ``max_px_per_frame`` are sampled
#: (see :mod:`miketalk.lipsync.timeline`).
Sampling = Literal["blur", "paper", "none"]
SAMPLINGS: tuple[str, ...] = get_args(Sampling)

#: How the mouth moves between visemes (:data:`miketalk.defaults.LIPSYNC_MODEL`).
LipsyncModel = Literal["paper", "learned", "trained"]
LIPSYNC_MODELS: tuple[str, ...] = get_args(LipsyncModel)

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
        raise MiketalkError(f"sampling must be one of {', '.join(SAMPLINGS)}, not {sampling!r}")
    return sampling  # type: ignore[return-value]


def check_lipsync_model(lipsync_model: object) -> LipsyncModel:
    """``lipsync_model`` checked to be one of :data:`LIPSYNC_MODELS`."""
    if lipsync_model not in LIPSYNC_MODELS:
        raise MiketalkError(
            f"lipsync model must be one of {', '.join(LIPSYNC_MODELS)}, not {lipsync_model!r}"
        )
    return lipsync_model  # type: ignore[return-value]


def check_max_slowdown(max_slowdown: object) -> float | None:
    """``max_slowdown`` (None: no cap) checked to be a finite number of at least 1."""
    if max_slowdown is None:
        return None
    if isinstance(max_slowdown, bool) or not isinstance(max_slowdown, numbers.Real):
        raise MiketalkError(f"max_slowdown must be a number of at least 1, not {max_slowdown!r}")
    value = float(max_slowdown)
    if not 1.0 <= value < float("inf"):  # also NaN
        raise MiketalkError(
            f"max_slowdown must be a finite number of at least 1 (1: the speech's own "
            f"duration), not {value:g}"
        )
    return value


def _in_range(value: object, name: str, bounds: tuple[float, float], unit: str) -> float:
    lo, hi = bounds
    message = f"{name} must be a number from {lo:g} to {hi:g} {unit}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise MiketalkError(f"{message}, not {value!r}")
    number = float(value)
    if not lo <= number <= hi:  # also NaN
        raise MiketalkError(f"{message}, not {number:g}")
    return number


def check_trajectory(trajectory: str | None, *, lipsync_model: str, recorded: bool) -> None:
    """A trajectory model asked for goes with the trained face, and ``heard`` with a recording
    (``recorded``); which models a face has is :meth:`~miketalk.draw.trained.TrainedFace.kind_for`'s
    check.

    Raises
    ------
    MiketalkError
        In one line, naming the command-line options.
    """
    if trajectory is None:
        return
    if lipsync_model != "trained":
        raise MiketalkError("--trajectory goes with --lipsync-model trained")
    if trajectory == "heard" and not recorded:
        raise MiketalkError(
            "the heard trajectory (--trajectory heard) listens to a recording: give one "
            "(--audio), or use window or regularized with typed text"
        )


def check_settings(
    *,
    fps: float,
    max_px_per_frame: float | None,
    sampling: Sampling,
    max_slowdown: float | None,
    lipsync_model: LipsyncModel,
) -> None:
    """Check ``say``'s settings together, before anything runs.

    Raises
    ------
    MiketalkError
        An fps or ``max_px_per_frame`` outside its range (the range is in the
        message), an unknown sampling or lipsync model, a ``max_slowdown``
        below 1 or given without ``sampling="paper"``.
    """
    check_fps(fps)
    check_lipsync_model(lipsync_model)
    if max_px_per_frame is not None:
        check_max_px(max_px_per_frame)
    check_sampling(sampling)
    check_max_slowdown(max_slowdown)
    if max_slowdown is not None and sampling != "paper":
        raise MiketalkError(
            "max_slowdown caps the paper mode's lengthening of the speech: it goes with "
            f"sampling 'paper', not {sampling!r}"
        )
