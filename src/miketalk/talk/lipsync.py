"""Lip-sync (paper §7): timed phones -> viseme transitions -> a morph parameter per frame.

Each phone contributes one keyframe at its middle (a diphthong two, at a quarter
and three quarters of it, one per nucleus). A viseme transition runs from one
keyframe to the next, as a diphone runs from the middle of one phone to the
middle of the next; a hold of the first viseme covers the first half-phone and a
hold of the last viseme the last, so that video and audio start and end
together. Frame ``k`` at time ``k / F`` takes the transition it falls in and
``alpha_k = (k/F - s(V_i)) / l(V_i)`` (Eq. 10).

Adaptive oversampling: a transition whose largest flow displacement ``D`` would
move more than ``max_px_per_frame`` per frame (``D / (l F)``) is lengthened to
``D / (max_px_per_frame F)`` by lengthening the phones it spans, and the audio
is re-synthesized with those durations, so that sound and picture stay in sync.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from itertools import pairwise
from typing import Any

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.backend import PendingSpeech, SpeechBackend
from miketalk.speech.types import Phone, Utterance
from miketalk.visemes import VisemeTable

#: ``displacement(a, b)``: the largest flow displacement in pixels from viseme a to b.
Displacement = Callable[[str, str], float]

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
    """Frame ``index`` at ``time = index / fps``: transition ``transition`` at ``alpha``."""

    index: int
    time: float
    transition: int
    alpha: float


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
        """JSON-ready form (the timeline file written beside each video)."""
        return {
            "fps": self.fps,
            "duration": self.duration,
            "phones": [asdict(p) for p in self.phones],
            "keyframes": [asdict(k) for k in self.keyframes],
            "transitions": [asdict(t) for t in self.transitions],
            "frames": [asdict(f) for f in self.frames],
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
                frames=tuple(FrameSample(**f) for f in doc["frames"]),
            )
        except (KeyError, TypeError) as err:
            raise MiketalkError(f"not a timeline: {type(err).__name__} {err}") from None


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


def plan(phones: Sequence[Phone], table: VisemeTable, fps: float, duration: float) -> Timeline:
    """Keyframes, transitions and per-frame alphas for timed phones."""
    if fps <= 0:
        raise MiketalkError(f"fps must be positive, not {fps}")
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


def largest_step(timeline: Timeline, displacement: Displacement) -> float:
    """The largest displacement in pixels between two consecutive frames.

    A frame pair inside one transition moves ``D * (alpha_2 - alpha_1)``; a pair
    across a boundary moves the rest of the first transition plus the start of
    the next one(s).
    """
    d = np.array([displacement(t.source, t.target) for t in timeline.transitions])
    position = np.array([f.transition + f.alpha for f in timeline.frames])
    # cumulative displacement along the stream at each frame: sum of whole
    # transitions before it plus alpha of the current one
    cum = np.concatenate([[0.0], np.cumsum(d)])
    whole = np.floor(position).astype(int)
    frac = position - whole
    along = cum[whole] + frac * d[np.minimum(whole, len(d) - 1)]
    return float(np.max(np.diff(along))) if len(along) > 1 else 0.0


#: Seconds added to every lengthened transition (see :func:`oversampled_durations`):
#: more than one sample at 8 kHz, far less than a frame.
TIME_MARGIN = 2e-4


def oversampled_durations(
    phones: Sequence[Phone],
    table: VisemeTable,
    fps: float,
    displacement: Displacement,
    max_px_per_frame: float,
) -> np.ndarray:
    """Phone durations lengthened so no transition moves faster than ``max_px_per_frame``.

    A transition from keyframe (phone a, fraction fa) to (phone b, fraction fb)
    lasts ``(1 - fa) d_a + fb d_b`` (``(fb - fa) d_a`` inside one diphthong).
    For each transition too short for its displacement ``D``, both phones are
    lengthened by the same amount so that it lasts ``D / (max F)`` plus
    :data:`TIME_MARGIN`: the engine quantises the times it is given (Festival
    prints them to the microsecond, and long text is spoken in chunks joined
    at whole audio samples), and the margin keeps the rounded transition from
    coming out a hair too short, so the largest step stays at or under
    ``max_px_per_frame``. Lengthening never shortens another transition, so a
    few passes settle it.

    Returns
    -------
    numpy.ndarray
        The new duration of every phone, seconds (unchanged where no transition
        is undersampled).
    """
    if max_px_per_frame <= 0:
        raise MiketalkError(f"max_px_per_frame must be positive, not {max_px_per_frame}")
    durations = np.array([p.duration for p in phones], dtype=np.float64)
    keys = keyframes(phones, table)
    pairs = list(pairwise(keys))
    need = [
        displacement(a.viseme, b.viseme) / (max_px_per_frame * fps) + TIME_MARGIN for a, b in pairs
    ]
    for _ in range(10):
        changed = False
        for (a, b), required in zip(pairs, need, strict=True):
            if a.phone == b.phone:
                coef = {a.phone: b.fraction - a.fraction}
            else:
                coef = {a.phone: 1.0 - a.fraction, b.phone: b.fraction}
            length = sum(c * durations[i] for i, c in coef.items())
            deficit = required - length
            if deficit > 1e-9:
                extra = deficit / sum(coef.values())
                for i in coef:
                    durations[i] += extra
                changed = True
        if not changed:
            break
    return durations


def synchronize(
    utterance: Utterance,
    table: VisemeTable,
    *,
    fps: float,
    displacement: Displacement,
    max_px_per_frame: float | None,
    backend: SpeechBackend | None = None,
) -> tuple[Utterance, Timeline]:
    """Plan the video for ``utterance``, oversampling and re-synthesizing if needed.

    Parameters
    ----------
    utterance : Utterance
        Festival's audio and phones.
    table : VisemeTable
        Phone -> viseme map.
    fps : float
        Frame rate F.
    displacement : callable
        ``displacement(a, b)``: largest flow displacement of transition a -> b, px.
    max_px_per_frame : float or None
        Oversampling threshold (paper: 2.5-3.0 px); None turns oversampling off.
    backend : SpeechBackend, optional
        Re-synthesizes the audio with the lengthened phones; required when a
        phone has to be lengthened.

    Returns
    -------
    (Utterance, Timeline)
        The (possibly re-synthesized) utterance and its timeline; the video has
        ``round(duration * fps)`` frames, ending with the audio within a frame.
    """
    retime = _retimer(table, fps, displacement, max_px_per_frame)
    durations = retime(utterance.phones)
    if durations is not None:
        if backend is None:
            raise MiketalkError("oversampling lengthens phones but no speech back-end given")
        utterance = backend.resynthesize(utterance, durations)
    return utterance, plan(utterance.phones, table, fps, utterance.duration)


def speak_in_sync(
    speech: PendingSpeech,
    table: VisemeTable,
    *,
    fps: float,
    displacement: Displacement,
    max_px_per_frame: float | None,
    on_planned: Callable[[tuple[Phone, ...]], object] | None = None,
) -> tuple[Utterance, Timeline]:
    """Finish a started synthesis and plan its video, oversampling where transitions move too fast.

    ``speech`` is ``backend.start(text)``. The same result as
    ``synchronize(backend.synthesize(text), ...)``, but the lengthened
    durations are dictated to the engine before it makes the wave
    (:meth:`PendingSpeech.finish`): one run of the engine, not two.

    Parameters
    ----------
    on_planned : callable, optional
        Called with the phones the engine predicted, before any retiming
        (what ``synchronize`` gets as ``utterance.phones``).

    Returns
    -------
    (Utterance, Timeline)
        The utterance as spoken and the timeline of its frames.
    """
    retimer = _retimer(table, fps, displacement, max_px_per_frame)

    def retime(phones: Sequence[Phone]) -> np.ndarray | None:
        if on_planned is not None:
            on_planned(tuple(phones))
        return retimer(phones)

    utterance = speech.finish(retime)
    return utterance, plan(utterance.phones, table, fps, utterance.duration)


def _retimer(
    table: VisemeTable, fps: float, displacement: Displacement, max_px_per_frame: float | None
) -> Callable[[Sequence[Phone]], np.ndarray | None]:
    """phones -> oversampled durations, or None where oversampling changes nothing."""

    def retime(phones: Sequence[Phone]) -> np.ndarray | None:
        if max_px_per_frame is None:
            return None
        old = np.array([p.duration for p in phones])
        new = oversampled_durations(phones, table, fps, displacement, max_px_per_frame)
        return None if np.allclose(new, old, rtol=0, atol=1e-6) else new

    return retime


def frame_count(duration: float, fps: float) -> int:
    """Frames for ``duration`` seconds at ``fps``: ``round(duration * fps)``, at least 1."""
    return max(1, math.floor(duration * fps + 0.5))
