"""Sampling fast transitions: motion blur, the paper's oversampling, and speech in sync.

A transition whose largest flow displacement ``D`` is crossed in a time ``l``
moves ``D / (l F)`` pixels per frame, and more than ``max_px_per_frame`` looks
like a jump. Three ways of sampling it (:data:`SAMPLINGS`):

``"blur"`` (the default; beyond the paper)
    The speech keeps its own timing. Where the mouth moves faster than
    ``max_px_per_frame`` per frame, more morphs than frames are rendered and
    each frame is their average over its exposure (:func:`motion_blur`), as a
    camera with a 360-degree shutter integrates the motion during a frame. No
    two consecutive morphs are more than ``max_px_per_frame`` apart.
``"paper"`` (the paper's adaptive oversampling)
    The transition is lengthened to ``D / (max_px_per_frame F)`` by lengthening
    the phones it spans, and the audio is spoken again with those durations
    (:func:`oversampled_durations`). ``max_slowdown`` caps how much longer the
    speech may become (:func:`capped_durations`); whatever is then still too
    fast is blurred.
``"none"``
    One morph per frame at the speech's own timing, however far apart.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from itertools import pairwise

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import (
    Sampling,
    check_max_slowdown,
    check_sampling,
    check_sampling_rules,
)
from miketalk.lipsync.timeline import FrameSample, Timeline, keyframes, plan
from miketalk.speech.backend import PendingSpeech, SpeechBackend
from miketalk.speech.types import Phone, Utterance
from miketalk.visemes import VisemeTable

#: ``displacement(a, b)``: the largest flow displacement in pixels from viseme a to b.
Displacement = Callable[[str, str], float]


#: The most morphs averaged into one frame.
MAX_SAMPLES = 256


def motion_blur(
    timeline: Timeline,
    *,
    displacement: Displacement,
    max_px_per_frame: float,
    max_samples: int = MAX_SAMPLES,
) -> Timeline:
    """The timeline with every frame that moves too fast blurred over its exposure.

    Frame ``k`` is exposed over ``[(k - 1/2) / F, (k + 1/2) / F]`` (clipped to the
    audio): the exposures tile time, as with a 360-degree shutter, and each is
    centred on the frame's time, so the sync of the point-sampled timeline is
    kept. A frame whose exposure sees no transition faster than
    ``max_px_per_frame * F`` pixels per second stays the one morph at its
    middle. Any other frame becomes the time average of its exposure by the
    midpoint rule: the part of each transition inside the exposure is cut into
    ``ceil(motion / max_px_per_frame)`` equal slices, each sampled at its middle
    and weighted by its duration. Consecutive morphs, within a frame and across
    frames, are then at most ``max_px_per_frame`` apart along the transitions
    (see :func:`largest_step`).

    Parameters
    ----------
    timeline : Timeline
        A point-sampled timeline (:func:`plan`).
    displacement : callable
        ``displacement(a, b)``: largest flow displacement of transition a -> b, px.
    max_px_per_frame : float
        The largest distance between consecutive morphs, px.
    max_samples : int
        The most morphs averaged into one frame; a frame that would need more
        gets this many, and the bound above no longer holds for it.

    Returns
    -------
    Timeline
        The same timeline, blurred frames carrying :attr:`FrameSample.samples`.
    """
    if not max_px_per_frame > 0:
        raise MiketalkError(f"max_px_per_frame must be positive, not {max_px_per_frame}")
    stream = timeline.transitions
    fps, duration = timeline.fps, timeline.duration
    starts = np.array([t.start for t in stream])
    ends = np.array([t.start + t.duration for t in stream])
    speed = np.array([displacement(t.source, t.target) / t.duration for t in stream])
    limit = max_px_per_frame * fps
    frames = []
    for frame in timeline.frames:
        lo = max(0.0, frame.time - 0.5 / fps)
        hi = min(duration, frame.time + 0.5 / fps)
        first = max(0, int(np.searchsorted(starts, lo, side="right")) - 1)
        last = max(first, int(np.searchsorted(starts, hi, side="left")) - 1)
        if hi <= lo or speed[first : last + 1].max() <= limit:
            frames.append(frame)
            continue
        pieces = []  # (transition, slice start, slice end, slices)
        for i in range(first, last + 1):
            a, b = max(lo, starts[i]), min(hi, ends[i])
            if b > a:
                n = max(1, math.ceil(speed[i] * (b - a) / max_px_per_frame - 1e-9))
                pieces.append([i, a, b, n])
        total = sum(p[3] for p in pieces)
        if total > max_samples:
            for p in pieces:
                p[3] = max(1, math.floor(p[3] * max_samples / total))
        samples = []
        for i, a, b, n in pieces:
            width = (b - a) / n
            for j in range(n):
                t = a + (j + 0.5) * width
                alpha = min(1.0, max(0.0, (t - starts[i]) / stream[i].duration))
                samples.append((int(i), float(alpha), float(width / (hi - lo))))
        frames.append(
            FrameSample(frame.index, frame.time, frame.transition, frame.alpha, tuple(samples))
        )
    return Timeline(
        fps=timeline.fps,
        duration=timeline.duration,
        phones=timeline.phones,
        keyframes=timeline.keyframes,
        transitions=timeline.transitions,
        frames=tuple(frames),
    )


def _along(timeline: Timeline, displacement: Displacement) -> Callable[[int, float], float]:
    """Distance travelled along the transition stream at (transition, alpha), px."""
    d = np.array([displacement(t.source, t.target) for t in timeline.transitions])
    cum = np.concatenate([[0.0], np.cumsum(d)])

    def along(transition: int, alpha: float) -> float:
        return float(cum[transition] + alpha * d[transition])

    return along


def _morph_positions(timeline: Timeline, displacement: Displacement) -> list[list[float]]:
    """Each frame's morphs as distances along the stream, in time order."""
    along = _along(timeline, displacement)
    return [
        [along(i, a) for i, a, _ in f.samples] if f.samples else [along(f.transition, f.alpha)]
        for f in timeline.frames
    ]


def largest_step(timeline: Timeline, displacement: Displacement) -> float:
    """The largest displacement in pixels between two consecutive rendered morphs.

    What the paper bounds by ``max_px_per_frame``. Without blur, a frame pair
    inside one transition moves ``D * (alpha_2 - alpha_1)`` and a pair across a
    boundary the rest of the first transition plus the start of the next
    one(s); a blurred frame's morphs (:attr:`FrameSample.samples`) are steps of
    their own, and so is the step from one frame's last morph to the next
    frame's first.
    """
    flat = [x for frame in _morph_positions(timeline, displacement) for x in frame]
    return float(np.max(np.diff(flat))) if len(flat) > 1 else 0.0


def largest_frame_motion(timeline: Timeline, displacement: Displacement) -> float:
    """The largest distance in pixels between the middles of two consecutive frames.

    How fast the mouth moves, in pixels per frame: for a point-sampled
    timeline it is :func:`largest_step`; for a blurred one it is how far the
    motion goes from one frame to the next (each frame's weighted mean
    position), which blurring leaves as it is and lengthening shrinks.
    """
    along = _along(timeline, displacement)
    middle = [
        sum(w * along(i, a) for i, a, w in f.samples) if f.samples else along(f.transition, f.alpha)
        for f in timeline.frames
    ]
    return float(np.max(np.diff(middle))) if len(middle) > 1 else 0.0


#: Seconds added to every lengthened transition (see :func:`oversampled_durations`):
#: more than one sample at 8 kHz, far less than a frame.
TIME_MARGIN = 2e-4


def oversampled_durations(
    phones: Sequence[Phone],
    table: VisemeTable,
    *,
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
    if not max_px_per_frame > 0:
        raise MiketalkError(f"max_px_per_frame must be positive, not {max_px_per_frame}")
    if not fps > 0:
        raise MiketalkError(f"fps must be positive, not {fps}")
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


def capped_durations(
    natural: Sequence[float], lengthened: Sequence[float], *, max_slowdown: float | None
) -> np.ndarray:
    """``lengthened`` pulled back towards ``natural`` so the total is at most ``max_slowdown``
    times the natural total.

    Every phone keeps the same fraction ``s`` of its lengthening, ``s`` chosen
    so that the speech lasts exactly ``max_slowdown`` times its own duration
    (``s = 1``, all of it, when that is already so; None: no cap).
    """
    natural = np.asarray(natural, dtype=np.float64)
    lengthened = np.asarray(lengthened, dtype=np.float64)
    if max_slowdown is None:
        return lengthened
    budget = (max_slowdown - 1.0) * natural.sum()
    extra = lengthened.sum() - natural.sum()
    if extra <= budget:
        return lengthened
    return natural + (lengthened - natural) * (budget / extra)


def synchronize(
    utterance: Utterance,
    table: VisemeTable,
    *,
    fps: float,
    displacement: Displacement,
    max_px_per_frame: float | None,
    sampling: Sampling = "blur",
    max_slowdown: float | None = None,
    backend: SpeechBackend | None = None,
) -> tuple[Utterance, Timeline]:
    """Plan the video for ``utterance``, sampling fast transitions as ``sampling`` says.

    Parameters
    ----------
    utterance : Utterance
        The engine's audio and phones.
    table : VisemeTable
        Phone -> viseme map.
    fps : float
        Frame rate F.
    displacement : callable
        ``displacement(a, b)``: largest flow displacement of transition a -> b, px.
    max_px_per_frame : float or None
        The largest step between consecutive morphs (paper: 2.5-3.0 px); None
        sets no limit (as ``sampling="none"``).
    sampling : {"blur", "paper", "none"}
        See the module docstring.
    max_slowdown : float, optional
        With ``sampling="paper"``: the speech may become at most this many
        times longer (None: as long as the limit needs).
    backend : SpeechBackend, optional
        Re-synthesizes the audio with the lengthened phones; required when a
        phone has to be lengthened.

    Returns
    -------
    (Utterance, Timeline)
        The (possibly re-synthesized) utterance and its timeline; the video has
        ``round(duration * fps)`` frames, ending with the audio within a frame.
    """
    retime = _retimer(table, fps, displacement, max_px_per_frame, sampling, max_slowdown)
    durations = retime(utterance.phones)
    if durations is not None:
        if backend is None:
            raise MiketalkError("oversampling lengthens phones but no speech back-end given")
        utterance = backend.resynthesize(utterance, durations)
    timeline = plan(utterance.phones, table, fps=fps, duration=utterance.duration)
    return utterance, _blurred(timeline, displacement, max_px_per_frame, sampling)


def speak_in_sync(
    speech: PendingSpeech,
    table: VisemeTable,
    *,
    fps: float,
    displacement: Displacement,
    max_px_per_frame: float | None,
    sampling: Sampling = "blur",
    max_slowdown: float | None = None,
    on_planned: Callable[[tuple[Phone, ...]], object] | None = None,
) -> tuple[Utterance, Timeline]:
    """Finish a started synthesis and plan its video, sampling as ``sampling`` says.

    ``speech`` is ``backend.start(text)``. The same result as
    ``synchronize(backend.synthesize(text), ...)``, but lengthened durations
    (``sampling="paper"``) are dictated to the engine before it makes the
    wave (:meth:`PendingSpeech.finish`): one run of the engine, not two.

    Parameters
    ----------
    on_planned : callable, optional
        Called with the phones the engine predicted, before any retiming
        (what ``synchronize`` gets as ``utterance.phones``).

    Other parameters are those of :func:`synchronize`.

    Returns
    -------
    (Utterance, Timeline)
        The utterance as spoken and the timeline of its frames.
    """
    retimer = _retimer(table, fps, displacement, max_px_per_frame, sampling, max_slowdown)

    def retime(phones: Sequence[Phone]) -> np.ndarray | None:
        if on_planned is not None:
            on_planned(tuple(phones))
        return retimer(phones)

    utterance = speech.finish(retime)
    timeline = plan(utterance.phones, table, fps=fps, duration=utterance.duration)
    return utterance, _blurred(timeline, displacement, max_px_per_frame, sampling)


def _blurred(
    timeline: Timeline, displacement: Displacement, max_px: float | None, sampling: Sampling
) -> Timeline:
    if max_px is None or sampling == "none":
        return timeline
    return motion_blur(timeline, displacement=displacement, max_px_per_frame=max_px)


def _retimer(
    table: VisemeTable,
    fps: float,
    displacement: Displacement,
    max_px_per_frame: float | None,
    sampling: Sampling,
    max_slowdown: float | None,
) -> Callable[[Sequence[Phone]], np.ndarray | None]:
    """phones -> oversampled durations, or None where nothing is lengthened."""
    max_slowdown = check_max_slowdown(max_slowdown)
    check_sampling_rules(check_sampling(sampling), max_slowdown)

    def retime(phones: Sequence[Phone]) -> np.ndarray | None:
        if max_px_per_frame is None or sampling != "paper":
            return None
        old = np.array([p.duration for p in phones])
        new = oversampled_durations(
            phones, table, fps=fps, displacement=displacement, max_px_per_frame=max_px_per_frame
        )
        new = capped_durations(old, new, max_slowdown=max_slowdown)
        return None if np.allclose(new, old, rtol=0, atol=1e-6) else new

    return retime
