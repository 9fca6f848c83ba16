"""Lip-sync (paper §7): timed phones -> viseme transitions -> a morph parameter per frame.

Each phone contributes one keyframe at its middle (a diphthong two, at a quarter
and three quarters of it, one per nucleus). A viseme transition runs from one
keyframe to the next, as a diphone runs from the middle of one phone to the
middle of the next; a hold of the first viseme covers the first half-phone and a
hold of the last viseme the last, so that video and audio start and end
together. Frame ``k`` at time ``k / F`` takes the transition it falls in and
``alpha_k = (k/F - s(V_i)) / l(V_i)`` (Eq. 10).

How the transitions are sampled when the mouth moves fast is
:mod:`miketalk.lipsync.sampling`'s job.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import (
    FPS_RANGE,
    MAX_PX_RANGE,
    SAMPLINGS,
    Sampling,
    check_fps,
    check_max_px,
    check_max_slowdown,
    check_sampling,
)
from miketalk.speech.types import Phone
from miketalk.visemes import VisemeTable

__all__ = [
    "FPS_RANGE",
    "MAX_PX_RANGE",
    "SAMPLINGS",
    "FrameSample",
    "Keyframe",
    "Sampling",
    "Timeline",
    "Transition",
    "check_fps",
    "check_max_px",
    "check_max_slowdown",
    "check_sampling",
    "frame_count",
    "keyframes",
    "plan",
    "sample_frames",
    "transitions",
]


_NUCLEUS_FRACTIONS = {1: (0.5,), 2: (0.25, 0.75)}


@dataclass(frozen=True)
class Keyframe:
    """A viseme shown in full at ``time`` (the middle of its phone, or of its nucleus)."""

    viseme: str
    time: float
    phone: int
    fraction: float


@dataclass(frozen=True)
class Transition:
    """A viseme transition V_i: from ``source`` at ``start`` to ``target`` ``duration`` later."""

    source: str
    target: str
    start: float
    duration: float


@dataclass(frozen=True)
class FrameSample:
    """Frame ``index`` at ``time = index / fps``: transition ``transition`` at ``alpha``.

    Attributes
    ----------
    samples : tuple of (int, float, float)
        Empty for a frame that is the one morph at (``transition``, ``alpha``).
        Otherwise the frame is motion-blurred: the weighted average of the
        morphs ``(transition, alpha, weight)``, in time order, over the frame's
        exposure; the weights sum to 1. ``transition`` and ``alpha`` still say
        where the frame's middle is.
    """

    index: int
    time: float
    transition: int
    alpha: float
    samples: tuple[tuple[int, float, float], ...] = field(default=())


@dataclass(frozen=True)
class Timeline:
    """Everything needed to render an utterance, and to check its sync."""

    fps: float
    duration: float
    phones: tuple[Phone, ...]
    keyframes: tuple[Keyframe, ...]
    transitions: tuple[Transition, ...]
    frames: tuple[FrameSample, ...]

    def to_dict(self) -> dict:
        """JSON-ready form (the timeline file written beside each video).

        A frame's ``samples`` is left out when it is empty.
        """
        frames = []
        for f in self.frames:
            row = asdict(f)
            if not f.samples:
                del row["samples"]
            frames.append(row)
        return {
            "fps": self.fps,
            "duration": self.duration,
            "phones": [asdict(p) for p in self.phones],
            "keyframes": [asdict(k) for k in self.keyframes],
            "transitions": [asdict(t) for t in self.transitions],
            "frames": frames,
        }

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Timeline:
        """The timeline :meth:`to_dict` wrote (other keys of ``doc`` are ignored).

        ``Timeline.from_dict(t.to_dict()) == t``, also through JSON (floats
        round-trip exactly).

        Raises
        ------
        MiketalkError
            If ``doc`` lacks a field or has a malformed one.
        """
        try:
            return cls(
                fps=doc["fps"],
                duration=doc["duration"],
                phones=tuple(Phone(**p) for p in doc["phones"]),
                keyframes=tuple(Keyframe(**k) for k in doc["keyframes"]),
                transitions=tuple(Transition(**t) for t in doc["transitions"]),
                frames=tuple(_frame_from_dict(f) for f in doc["frames"]),
            )
        except (KeyError, TypeError, ValueError) as err:
            raise MiketalkError(f"not a timeline: {type(err).__name__} {err}") from None

    @property
    def morph_count(self) -> int:
        """How many morphs rendering the timeline draws (a blurred frame draws several)."""
        return sum(max(1, len(f.samples)) for f in self.frames)


def _frame_from_dict(row: Mapping[str, Any]) -> FrameSample:
    samples = tuple((int(i), float(a), float(w)) for i, a, w in row.get("samples", ()))
    return FrameSample(**{**row, "samples": samples})


def keyframes(phones: Sequence[Phone], table: VisemeTable) -> list[Keyframe]:
    """One keyframe per phone at its middle; two for a diphthong (its nuclei).

    Raises
    ------
    MiketalkError
        For a phone the viseme table does not know.
    """
    out = []
    for i, phone in enumerate(phones):
        visemes = table.visemes_of(phone.name)
        for viseme, f in zip(visemes, _NUCLEUS_FRACTIONS[len(visemes)], strict=True):
            out.append(Keyframe(viseme, phone.start + f * phone.duration, i, f))
    return out


def transitions(keys: Sequence[Keyframe], duration: float) -> list[Transition]:
    """The viseme transition stream, covering ``[0, duration]`` without gaps (Eq. 8)."""
    if not keys:
        raise MiketalkError("no phones to make transitions from")
    times = [0.0, *(k.time for k in keys), duration]
    names = [keys[0].viseme, *(k.viseme for k in keys), keys[-1].viseme]
    out = []
    for i in range(len(times) - 1):
        if times[i + 1] > times[i]:
            out.append(Transition(names[i], names[i + 1], times[i], times[i + 1] - times[i]))
    return out


def sample_frames(stream: Sequence[Transition], fps: float, duration: float) -> list[FrameSample]:
    """Frame ``k`` at ``k / fps`` for ``k < round(duration * fps)``, with its alpha (Eq. 10)."""
    n = frame_count(duration, fps)
    starts = np.array([t.start for t in stream])
    lengths = np.array([t.duration for t in stream])
    times = np.arange(n) / fps
    which = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(stream) - 1)
    alpha = np.clip((times - starts[which]) / lengths[which], 0.0, 1.0)
    return [FrameSample(int(k), float(times[k]), int(which[k]), float(alpha[k])) for k in range(n)]


def plan(phones: Sequence[Phone], table: VisemeTable, *, fps: float, duration: float) -> Timeline:
    """Keyframes, transitions and per-frame alphas for timed phones (one morph per frame).

    Parameters
    ----------
    phones : sequence of Phone
        The timed phones.
    table : VisemeTable
        Phone -> viseme map.
    fps : float
        Frame rate, > 0.
    duration : float
        Seconds of audio the video covers.
    """
    if not isinstance(fps, int | float) or not math.isfinite(fps) or fps <= 0:
        raise MiketalkError(f"fps must be a positive number, not {fps!r}")
    keys = keyframes(phones, table)
    stream = transitions(keys, duration)
    return Timeline(
        fps=fps,
        duration=duration,
        phones=tuple(phones),
        keyframes=tuple(keys),
        transitions=tuple(stream),
        frames=tuple(sample_frames(stream, fps, duration)),
    )


def frame_count(duration: float, fps: float) -> int:
    """Frames for ``duration`` seconds at ``fps``: ``round(duration * fps)``, at least 1."""
    return max(1, math.floor(duration * fps + 0.5))
