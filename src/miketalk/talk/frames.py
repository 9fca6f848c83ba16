"""An utterance's frames drawn and handed over as a stream's chunks, each with its sound.

:func:`draw_utterance` is the engine's last step: the drawing renders the timeline's frames
(composited into the person's own frames when there is a background), each goes out as a
:class:`~miketalk.talk.stream.Chunk` with the samples played while it shows, and once they
are all out the motion is measured. What the engine made besides the frames is an
:class:`Uttered`: the writers (:mod:`miketalk.talk.publish`) put it in the timeline JSON.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.talk.stream import Chunk, Emitter

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    import numpy as np

    from miketalk.composite.background import Background
    from miketalk.draw.registry import Drawing
    from miketalk.lipsync.motion import JerkMeter, Motion, StepMeter
    from miketalk.lipsync.timeline import Timeline
    from miketalk.model.face import Model
    from miketalk.speech.acoustic import Recording
    from miketalk.speech.types import Utterance
    from miketalk.talk.utterance import Spoken

__all__ = ["Uttered", "draw_utterance", "measured", "mouth_compositing", "sample_bounds"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Uttered:
    """What the engine made of an utterance, its frames aside.

    Attributes
    ----------
    timeline : Timeline
        The timeline of its frames.
    motion : Motion
        The measures of its motion.
    extra : dict
        What its JSON says besides the timeline and the motion (the text, the settings).
    words : tuple of str
        What was said.
    duration : float
        Seconds of sound.
    lipsync_model : str
    trajectory : str or None
    utterance : Utterance or None
        Synthesized speech as spoken; None for a recording.
    """

    timeline: Timeline
    motion: Motion
    extra: dict
    words: tuple[str, ...]
    duration: float
    lipsync_model: str
    trajectory: str | None = None
    utterance: Utterance | None = None

    def spoken(self, video: Path | None, timeline_json: Path | None) -> Spoken:
        """The :class:`~miketalk.talk.utterance.Spoken` of it written to ``video`` (None: a
        pipe) and ``timeline_json`` (None: not written)."""
        from miketalk.talk.utterance import Spoken

        return Spoken(
            self.timeline, self.motion, video, timeline_json, words=self.words,
            duration=self.duration, lipsync_model=self.lipsync_model,
            trajectory=self.trajectory, utterance=self.utterance,
        )  # fmt: skip


def sample_bounds(index: int, rate: int, fps: float) -> int:
    """The first sample of frame ``index``: ``round(index * rate / fps)``, with ``fps`` the
    exact fraction the encoder uses (so the chunks' sound joined is
    :func:`~miketalk.media.video.write_mp4`'s, fitted to the frames)."""
    return round(Fraction(index) * rate / Fraction(fps).limit_denominator(1001))


def draw_utterance(
    emitter: Emitter,
    *,
    model: Model,
    timeline: Timeline,
    samples: np.ndarray,
    rate: int,
    drawing: Drawing,
    recording: Recording | None = None,
    progress: bool = False,
    background: Background | None = None,
    max_px_per_frame: float | None = None,
    first: int = 0,
    jerk: JerkMeter | None = None,
    bar=None,
    compositing=None,
    part: tuple[int, int] | None = None,
) -> tuple:
    """Render ``timeline``'s frames and emit each with its sound; return the drawing's
    weights and states (:data:`~miketalk.draw.registry.Frames`).

    The frames are numbered from ``first`` (a sentence after others); the sound is
    ``samples`` padded with silence or cut to the frames' length, frame ``k`` carrying
    samples :func:`sample_bounds` ``(k)`` to ``(k + 1)``.

    Parameters
    ----------
    emitter : Emitter
        The stream's producer side; it waits while the reader is behind, and raises
        :class:`~miketalk.talk.stream.Cancelled` once the stream is stopped.
    drawing : Drawing
        What draws the frames (:mod:`miketalk.draw.registry`).
    recording : Recording, optional
        The recording the frames follow (the trained face's ``heard`` trajectory listens).
    background : Background, optional
        Frames of the person the mouth is composited into; None: the model's still face.
    max_px_per_frame : float, optional
        The step limit the learned lip-sync keeps by blurring its path.
    first : int
        The number of the first frame (the frames of the sentences before).
    jerk : JerkMeter, optional
        Measures the frames' jerk (one meter for all the sentences of an utterance).
    bar : tqdm, optional
        A progress bar to count the frames on (one for all the sentences), instead of
        ``progress``'s own.
    compositing : MouthCompositing, optional
        ``background``'s compositing, made once for all the sentences
        (:func:`mouth_compositing`); None: made here.
    part : tuple of int, optional
        ``(lo, hi)``: only the timeline's frames ``lo`` to ``hi`` (a sentence's frames
        drawn before the next sentence is known, :meth:`~miketalk.draw.registry.Drawing.
        settled`, then the rest); None: all.
    """
    from contextlib import closing

    from miketalk.lipsync.motion import JerkMeter

    for t in timeline.transitions:  # every viseme must be in the model before we start
        model.displacement(t.source, t.target)
    started = time.perf_counter()
    n = len(timeline.frames)
    lo, hi = (0, n) if part is None else part
    fps = timeline.fps
    base = sample_bounds(first, rate, fps)
    sound = _fit(samples, sample_bounds(first + n, rate, fps) - base)
    if compositing is None and background is not None:
        compositing = mouth_compositing(model, background)
    region = compositing.region if compositing is not None else None
    jerk = jerk if jerk is not None else JerkMeter(region)
    rendered, weights, states = drawing.frames(
        model, timeline, recording=recording, max_px_per_frame=max_px_per_frame, region=region,
        part=part,
    )  # fmt: skip
    frames = jerk.watch(rendered)
    if compositing is not None:  # only the region compositing reads is drawn (and measured)
        frames = compositing.frames(frames, fps=fps, i420=True, start=first + lo)
    if progress and bar is None:
        from tqdm import tqdm

        frames = tqdm(frames, total=hi - lo, desc="rendering", unit="frame")
    with closing(rendered):
        start = sample_bounds(first + lo, rate, fps) - base
        for k, frame in enumerate(frames, first + lo):
            end = sample_bounds(k + 1, rate, fps) - base
            emitter.emit(Chunk(k, frame, sound[start:end], fps))
            start = end
            if bar is not None:
                bar.update(1)
    log.info("rendered %d frames in %.2f s", hi - lo, time.perf_counter() - started)
    return weights, states


def mouth_compositing(model: Model, background: Background | None):
    """How the mouth goes into ``background`` (:class:`~miketalk.composite.for_model.
    MouthCompositing`: the renders' region it reads, each frame's placement), or None."""
    if background is None:
        return None
    from miketalk.composite.for_model import MouthCompositing

    return MouthCompositing(model, background)


def measured(
    timeline: Timeline, model: Model, drawing: Drawing, *, natural_duration: float,
    jerk: JerkMeter, weights=None, states=None, steps: StepMeter | None = None,
) -> Motion:  # fmt: skip
    """The measures of the motion of ``timeline`` as drawn (:func:`~miketalk.lipsync.motion.
    measure`: the drawing's ``weights`` and ``states``, or ``steps`` measured of them)."""
    from miketalk.lipsync.motion import measure

    return measure(
        timeline, model.displacement, natural_duration=natural_duration, jerk=jerk,
        weights=weights, own_frames=drawing.own_frames, states=states, steps=steps,
    )  # fmt: skip


def _fit(audio: np.ndarray, n_samples: int) -> np.ndarray:
    """``audio`` cut to ``n_samples`` or padded with silence."""
    import numpy as np

    if audio.size >= n_samples:
        return audio[:n_samples]
    return np.concatenate([audio, np.zeros(n_samples - audio.size, np.int16)])
