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

import logging
import os
import time
from collections.abc import Sequence
from dataclasses import asdict
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.draw.registry import Drawing
from miketalk.errors import MiketalkError
from miketalk.lipsync.sampling import speak_in_sync
from miketalk.lipsync.settings import LipsyncSettings, Sampling
from miketalk.lipsync.timeline import keyframes
from miketalk.model.face import Model, open_model
from miketalk.speech.backend import PendingSpeech, SpeechBackend, get_backend
from miketalk.speech.types import Phone
from miketalk.talk.output import check_output
from miketalk.talk.recorded import Recorded, say_recording
from miketalk.talk.utterance import Spoken, own_frames_doc, write_utterance
from miketalk.visemes import VisemeTable, default_table

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    from miketalk.composite.background import Background


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
    settings = settings if settings is not None else LipsyncSettings()
    recorded = isinstance(speech, Recorded)
    pending: PendingSpeech | None = speech if isinstance(speech, PendingSpeech) else None
    try:
        if recorded and settings.sampling == Sampling.PAPER:
            raise MiketalkError(
                "sampling 'paper' lengthens the speech, and a recording cannot be lengthened: "
                "use blur (the default) or none"
            )
        drawing = model.drawing(settings.model, trajectory=settings.trajectory, recorded=recorded)
        inputs = (*inputs, *((speech.audio, speech.timings) if recorded else ()))
        output = check_output(output, overwrite=overwrite, inputs=inputs)
        if recorded:
            return say_recording(
                speech, output, model=model, settings=settings, drawing=drawing,
                table=table or default_table(), progress=progress, overwrite=overwrite,
                background=background, inputs=inputs,
            )  # fmt: skip
        if pending is None:
            pending = (backend or get_backend("festival")).start(str(speech))
    except BaseException:
        if pending is not None:
            pending.close()
        raise
    return _say_text(
        pending, output, model=model, settings=settings, drawing=drawing,
        table=table or default_table(), progress=progress, overwrite=overwrite,
        background=background, inputs=inputs,
    )  # fmt: skip


def _say_text(
    speech: PendingSpeech,
    output: Path,
    *,
    model: Model,
    settings: LipsyncSettings,
    drawing: Drawing,
    table: VisemeTable,
    progress: bool,
    overwrite: bool,
    background: Background | None,
    inputs: Sequence[str | os.PathLike[str] | None],
) -> Spoken:
    """:func:`say` of synthesized speech, once its settings and output are checked."""
    from miketalk.composite.background import background_doc

    started = time.perf_counter()
    planned: list[tuple[Phone, ...]] = []
    max_px_per_frame = settings.max_px_per_frame

    def on_planned(phones: tuple[Phone, ...]) -> None:
        # retiming changes when visemes are shown, never which: the flows the
        # render needs are read while the engine makes the wave
        planned.append(phones)
        keys = keyframes(phones, table)
        model.prefetch((a.viseme, b.viseme) for a, b in pairwise(keys))

    with speech:
        utterance, timeline = speak_in_sync(
            speech,
            table,
            fps=settings.fps,
            displacement=model.displacement,
            max_px_per_frame=max_px_per_frame,
            sampling=settings.sampling.value,
            max_slowdown=settings.max_slowdown,
            on_planned=on_planned,
        )
    # A voice that sets its own durations (HTS) speaks other times than it planned:
    # unless the paper's mode dictated them, the phones as spoken are the natural ones.
    lengthened = settings.sampling == Sampling.PAPER and max_px_per_frame is not None
    planned_phones = planned[-1] if planned and lengthened else utterance.phones
    planned_duration = round(planned_phones[-1].end * utterance.rate) / utterance.rate
    log.info(
        "speech: %.2f s (%.2f s at its own timing), %d phones; %d frames, %d morphs",
        utterance.duration, planned_duration, len(utterance.phones), len(timeline.frames),
        timeline.morph_count,
    )  # fmt: skip
    motion = write_utterance(
        output,
        model=model,
        timeline=timeline,
        samples=utterance.samples,
        rate=utterance.rate,
        natural_duration=planned_duration,
        extra={
            "text": utterance.text,
            "sampling": settings.sampling.value if max_px_per_frame is not None else "none",
            "max_px_per_frame": max_px_per_frame,
            "max_slowdown": settings.max_slowdown,
            "lipsync_model": drawing.lipsync_model.value,
            "planned_phones": [asdict(p) for p in planned_phones],
            # the wav ends on the sample nearest the last phone's end (Utterance's invariant)
            "planned_duration": planned_duration,
        }
        | (own_frames_doc(drawing) if drawing.own_frames else {})
        | background_doc(background),
        drawing=drawing,
        progress=progress,
        overwrite=overwrite,
        background=background,
        inputs=inputs,
        max_px_per_frame=max_px_per_frame,
    )
    log.info("say took %.2f s", time.perf_counter() - started)
    return Spoken(
        timeline, motion, output, output.with_suffix(".json"),
        words=tuple(utterance.text.split()), duration=utterance.duration,
        lipsync_model=drawing.lipsync_model.value, trajectory=drawing.trajectory,
        utterance=utterance,
    )  # fmt: skip


__all__ = ["Recorded", "Spoken", "open_model", "say"]
