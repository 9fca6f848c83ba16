"""The one entry point of saying things: a text or a recording in, the face's mp4 out.

:func:`say` takes typed text (Festival speaks it) or a :class:`Recorded` recording (its
phones found by forced alignment, :mod:`miketalk.talk.recorded`), one
:class:`~miketalk.lipsync.settings.LipsyncSettings`, and the face; it writes two files:
``NAME.mp4`` and, beside it, ``NAME.json``, the timeline of its frames and the measures of
its motion (:mod:`miketalk.lipsync.motion`). They are replaced together or not at all
(:func:`miketalk.media.atomic.atomic_paths`): on any failure, Ctrl-C or
SIGTERM included, an older pair is left as it was, and a run killed outright
leaves nothing the next run does not tidy. The output is checked before any
work (:func:`check_output`), and so are the settings.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from itertools import pairwise
from typing import TYPE_CHECKING

from miketalk.draw.registry import Drawing
from miketalk.errors import MiketalkError
from miketalk.lipsync.sampling import speak_in_sync
from miketalk.lipsync.settings import LipsyncSettings, Sampling
from miketalk.lipsync.timeline import keyframes
from miketalk.model.face import Model, open_model
from miketalk.speech.backend import PendingSpeech, SpeechBackend, get_backend
from miketalk.speech.types import Phone, Utterance
from miketalk.talk.frames import Uttered, draw_utterance, measured, mouth_compositing
from miketalk.talk.output import check_output
from miketalk.talk.recorded import Aligned, Recorded, say_recording
from miketalk.talk.sentences import Joined, ahead, in_context
from miketalk.talk.stream import Emitter, Stream, StreamInfo
from miketalk.talk.utterance import Spoken, own_frames_doc
from miketalk.visemes import VisemeTable, default_table

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    from miketalk.composite.background import Background
    from miketalk.lipsync.timeline import Timeline


log = logging.getLogger(__name__)


def say(
    speech: str | PendingSpeech | Recorded,
    output: str | os.PathLike[str],
    *,
    model: Model,
    settings: LipsyncSettings | None = None,
    backend: SpeechBackend | None = None,
    table: VisemeTable | None = None,
    progress: bool = False,
    overwrite: bool = False,
    background: Background | None = None,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> Spoken:
    """Make the face say ``speech``: an mp4 at ``output``, its timeline JSON beside it.

    :func:`stream` of it read by :func:`miketalk.talk.publish.publish`.

    The JSON (``output`` with suffix ``.json``) is :meth:`Timeline.to_dict`
    plus ``format`` (:data:`~miketalk.talk.output.TIMELINE_FORMAT`), ``text``,
    ``sampling``, ``max_px_per_frame``, ``max_slowdown``, ``lipsync_model`` (and
    ``trajectory`` for the trained face), for typed text ``planned_phones`` (the phones
    the engine predicted, before the paper's mode lengthened any) and
    ``planned_duration``, for a recording ``audio``; then ``largest_step_px`` and
    ``motion`` (:class:`~miketalk.lipsync.motion.Motion`).
    :func:`~miketalk.talk.utterance.read_said` reads it back. It is strict JSON (no NaN).

    Parameters
    ----------
    speech : str, PendingSpeech or Recorded
        Typed text; or its synthesis already started with ``backend.start(text)`` (the
        engine then analyses the text while the caller loads the model; ``say`` finishes
        or closes it); or a recording with what it says (:class:`Recorded`), whose own
        sound and timing the video keeps.
    output : path-like
        The ``.mp4`` to write.
    model : Model
        The face: its visemes and their flows, and what else it holds.
    settings : LipsyncSettings, optional
        Frame rate, step limit, sampling, lip-sync model (None: the model's own:
        :func:`~miketalk.lipsync.settings.resolve_lipsync_model`) and trajectory. The
        default settings when None. ``sampling="paper"`` lengthens the speech (paper §7),
        which a recording cannot be.
    backend : SpeechBackend, optional
        The engine for a ``str`` text (default Festival).
    table : VisemeTable, optional
        Phone-to-viseme table (default: the paper's).
    progress : bool
        Draw a progress bar on stderr.
    overwrite : bool
        Replace an mp4 or a ``NAME.json`` that miketalk did not write
        (:mod:`miketalk.media.ownership`; never an input).
    background : Background, optional
        Frames of the person the mouth is composited into
        (:mod:`miketalk.composite.background`); None: the model's still face.
    inputs : sequence of path-like
        Files the caller read for this utterance (a text file, a video), never written
        over; a recording's audio and timings are added.

    Returns
    -------
    Spoken
        The timeline of the frames, the measures of the motion, the files written, what
        was said and what drew it.

    Raises
    ------
    MiketalkError
        A bad setting or output (before anything runs), a model without the lip-sync
        model asked for, nothing speakable, a failing engine, aligner or model.
    """
    from miketalk.talk.publish import publish

    if isinstance(speech, Recorded):
        inputs = (*inputs, speech.audio, speech.timings)
    try:
        output = check_output(output, overwrite=overwrite, inputs=inputs)
    except BaseException:
        if isinstance(speech, PendingSpeech):
            speech.close()
        raise
    utterance = Stream(
        producer(
            speech, model=model, settings=settings, backend=backend, table=table,
            progress=progress, background=background,
        )
    )  # fmt: skip
    return publish(utterance, output, overwrite=overwrite, inputs=inputs)


def producer(
    speech: str | PendingSpeech | Recorded,
    *,
    model: Model,
    settings: LipsyncSettings | None = None,
    backend: SpeechBackend | None = None,
    table: VisemeTable | None = None,
    progress: bool = False,
    background: Background | None = None,
    aligned: Callable[[], Aligned] | None = None,
) -> Callable[[Emitter], Uttered]:
    """The work of the face saying ``speech``, for a :class:`~miketalk.talk.stream.Stream`
    of timed chunks (``Stream(producer(...))``). The parameters are :func:`say`'s;
    ``aligned``: a recording's alignment, started before (:func:`~miketalk.talk.recorded.
    aligning`).

    Raises
    ------
    MiketalkError
        At once: the paper's sampling with a recording, a model without the lip-sync model
        asked for (a started ``speech`` is then closed). The rest (nothing speakable, a
        failing engine or aligner) is raised to the stream's reader.
    """
    settings = settings if settings is not None else LipsyncSettings()
    recorded = isinstance(speech, Recorded)
    table = table or default_table()
    try:
        if recorded and settings.sampling == Sampling.PAPER:
            raise MiketalkError(
                "sampling 'paper' lengthens the speech, and a recording cannot be lengthened: "
                "use blur (the default) or none"
            )
        drawing = model.drawing(settings.model, trajectory=settings.trajectory, recorded=recorded)
    except BaseException:
        if isinstance(speech, PendingSpeech):
            speech.close()
        raise
    common = {"model": model, "settings": settings, "drawing": drawing, "table": table,
              "progress": progress, "background": background}  # fmt: skip

    def produce(emitter: Emitter) -> Uttered:
        if isinstance(speech, Recorded):
            return say_recording(emitter, speech, aligned=aligned, **common)
        pending = speech
        if not isinstance(pending, PendingSpeech):
            pending = (backend or get_backend("festival")).start_sentences(str(speech))
        return _say_text(emitter, pending, **common)

    return produce


def _say_text(
    emitter: Emitter,
    speech: PendingSpeech,
    *,
    model: Model,
    settings: LipsyncSettings,
    drawing: Drawing,
    table: VisemeTable,
    progress: bool,
    background: Background | None,
) -> Uttered:
    """The stream of synthesized speech, once its settings are checked: sentence by
    sentence (:meth:`PendingSpeech.sentences`), the next spoken (:func:`ahead`) while the
    face draws this one, the sentences then joined (:class:`Joined`)."""
    from miketalk.composite.background import background_doc
    from miketalk.lipsync.motion import JerkMeter, StepMeter

    started = time.perf_counter()
    max_px_per_frame = settings.max_px_per_frame
    # A voice that sets its own durations (HTS) speaks other times than it planned:
    # unless the paper's mode dictated them, the phones as spoken are the natural ones.
    lengthened = settings.sampling == Sampling.PAPER and max_px_per_frame is not None

    def spoken(sentence: PendingSpeech) -> tuple[Utterance, Timeline, tuple[Phone, ...]]:
        planned: list[tuple[Phone, ...]] = []

        def on_planned(phones: tuple[Phone, ...]) -> None:
            # retiming changes when visemes are shown, never which: the flows the
            # render needs are read while the engine makes the wave
            planned.append(phones)
            keys = keyframes(phones, table)
            model.prefetch((a.viseme, b.viseme) for a, b in pairwise(keys))

        utterance, timeline = speak_in_sync(
            sentence,
            table,
            fps=settings.fps,
            displacement=model.displacement,
            max_px_per_frame=max_px_per_frame,
            sampling=settings.sampling.value,
            max_slowdown=settings.max_slowdown,
            on_planned=on_planned,
        )
        return utterance, timeline, planned[-1] if planned and lengthened else utterance.phones

    joined = Joined(settings.fps)
    compositing = mouth_compositing(model, background)  # once: each frame's placement
    jerk = JerkMeter(compositing.region if compositing is not None else None)
    steps = StepMeter(model.displacement)  # the learned drawing's, measured as it draws
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(desc="rendering", total=0, unit="frame")  # its total grows by sentence
    drawn_with = {"drawing": drawing, "progress": progress, "background": background,
                  "max_px_per_frame": max_px_per_frame, "jerk": jerk, "bar": bar,
                  "compositing": compositing}  # fmt: skip
    with (
        speech,
        contextlib.closing(bar) if bar is not None else contextlib.nullcontext(),
        contextlib.closing(
            ahead((spoken(s) for s in speech.sentences()), check=emitter.check)
        ) as said,
    ):
        before, now = None, next(said, None)
        while now is not None:
            utterance, timeline, planned = now
            if before is None:
                emitter.info(StreamInfo(fps=timeline.fps, rate=utterance.rate))
            if bar is not None:
                bar.total += len(timeline.frames)
                bar.refresh()

            # the frames the next sentence cannot change are drawn (and played) before it
            # is known: the first frame waits for the first sentence only
            n, head = len(timeline.frames), drawing.settled(timeline)
            sentence = {"model": model, "samples": utterance.samples, "rate": utterance.rate,
                        "first": joined.frames} | drawn_with  # fmt: skip
            drawn = []
            if head:
                drawn.append(draw_utterance(
                    emitter, timeline=in_context(timeline, before, None), part=(0, head),
                    **sentence))  # fmt: skip
            after = next(said, None)  # Festival made it while the face drew the head
            if head < n:
                drawn.append(draw_utterance(
                    emitter, timeline=in_context(timeline, before, after), part=(head, n),
                    **sentence))  # fmt: skip
            weights, states = _joined_parts(drawn)
            if weights is not None:
                steps.add(weights, states)
            joined.add(utterance, timeline, planned)
            before, now = now, after
    timeline, utterance = joined.timeline(), joined.utterance(speech.text)
    planned_duration = (
        joined.planned_duration if not joined.one
        else round(planned[-1].end * utterance.rate) / utterance.rate
    )  # fmt: skip
    planned_phones = planned if joined.one else tuple(joined.planned)
    log.info(
        "speech: %.2f s (%.2f s at its own timing), %d sentences, %d phones; %d frames, "
        "%d morphs", utterance.duration, planned_duration, len(joined.chunks),
        len(utterance.phones), len(timeline.frames), timeline.morph_count,
    )  # fmt: skip
    motion = measured(
        timeline, model, drawing, natural_duration=planned_duration, jerk=jerk,
        steps=steps if steps.frames else None,
    )  # fmt: skip
    extra = {
        "text": utterance.text,
        "sampling": settings.sampling.value if max_px_per_frame is not None else "none",
        "max_px_per_frame": max_px_per_frame,
        "max_slowdown": settings.max_slowdown,
        "lipsync_model": drawing.lipsync_model.value,
        "planned_phones": [asdict(p) for p in planned_phones],
        # the wav ends on the sample nearest the last phone's end (Utterance's invariant)
        "planned_duration": planned_duration,
    }
    extra |= (own_frames_doc(drawing) if drawing.own_frames else {}) | background_doc(background)
    log.info("say took %.2f s", time.perf_counter() - started)
    return Uttered(
        timeline, motion, extra, words=tuple(utterance.text.split()),
        duration=utterance.duration, lipsync_model=drawing.lipsync_model.value,
        trajectory=drawing.trajectory, utterance=utterance,
    )  # fmt: skip


def _joined_parts(drawn: list[tuple]) -> tuple:
    """The weights and states of a sentence drawn in parts (each None, or a list)."""
    weights = [list(w) for w, _ in drawn if w is not None]
    states = [list(s) for _, s in drawn if s is not None]
    return (
        [w for part in weights for w in part] if len(weights) == len(drawn) else None,
        [s for part in states for s in part] if len(states) == len(drawn) else None,
    )


__all__ = ["Recorded", "Spoken", "open_model", "producer", "say"]
