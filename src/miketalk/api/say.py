"""``say``: a text or a recording in, an mp4 of the model's face speaking it out.

:func:`check` makes every check of a ``say`` or ``dub`` that needs no file written (the
settings against the speech and the model's small files) and settles the lip-sync model;
:func:`say` makes it, then starts Festival (it analyses the text while the model opens),
opens the model and its background, settles the frame rate and draws the utterance
as a stream of timed chunks (:func:`say_stream`: a frame and its sound at a time, a
bounded queue, cancellable); :func:`say` writes that stream to the mp4 pair or a pipe.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from miketalk import defaults
from miketalk.api.models import OpenModels, opened
from miketalk.api.results import SayResult
from miketalk.api.settings import DubSettings, SaySettings, SpeechSettings, check_recorded_speech
from miketalk.errors import SettingError
from miketalk.lipsync.settings import LipsyncModel, Sampling
from miketalk.speech.festival.voices import DEFAULT_VOICE
from miketalk.talk.speech import Recorded, Speech

if TYPE_CHECKING:
    from miketalk.speech.backend import PendingSpeech
    from miketalk.talk.frames import Uttered
    from miketalk.talk.stream import Emitter, Stream
    from miketalk.talk.utterance import Spoken

__all__ = ["Recorded", "Speech", "check", "say", "say_stream", "write_fragmented"]

log = logging.getLogger("miketalk")


def check(
    settings: SpeechSettings, *, recorded: bool, dub: bool = False
) -> tuple[Path, LipsyncModel]:
    """Every check of a ``say`` (or with ``dub`` a ``dub``) of a recording (``recorded``) or of
    typed text that needs no file written: the settings against the speech, the model asked
    for, and what it holds; before Festival or numpy start.

    Returns
    -------
    (Path, LipsyncModel)
        The model's directory, and the lip-sync model the utterance is drawn with.

    Raises
    ------
    MiketalkError
        In one line (a :class:`~miketalk.errors.SettingError` names the settings): a setting
        for typed text given with a recording, the paper's sampling with a voice that sets its
        own durations, no model there, a model without the lip-sync model asked for, a dub
        with a model not built from video of a person.
    """
    from miketalk.model.parts import choose_lipsync_model, model_path

    if recorded:
        check_recorded_speech(settings)
    else:
        from miketalk.speech.festival.voices import get_voice

        voice = get_voice(settings.voice or DEFAULT_VOICE)
        if settings.sampling == Sampling.PAPER and not voice.follows_durations:
            raise SettingError(
                f"the {voice.name} voice sets its own phone durations, so {{sampling}} paper "
                "cannot lengthen them: use {sampling} blur (the default) or {voice} kal or ked"
            )
    directory = model_path(settings.model)
    if dub:
        from miketalk.model.background import has_background

        if not has_background(directory):
            raise SettingError(
                f"the model {directory} was not built from video of a person: dub needs a "
                "{model} built from clips of the person in the video"
            )
    chosen = choose_lipsync_model(
        directory, settings.lipsync_model, trajectory=settings.trajectory, recorded=recorded
    )
    return directory, chosen


@dataclass(frozen=True)
class Checked:
    """An utterance checked, before its work: what :func:`checked` settled."""

    output: Path
    model_dir: Path
    lipsync_model: LipsyncModel
    inputs: tuple[str | os.PathLike[str] | None, ...]
    overwrite: bool


def checked(
    speech: Speech,
    output: str | os.PathLike[str],
    settings: SpeechSettings,
    *,
    inputs: Sequence[str | os.PathLike[str] | None],
    dub: bool = False,
) -> Checked:
    """:func:`check`, then the output (:func:`miketalk.talk.output.check_output`)."""
    from miketalk.talk.output import check_output

    recorded = isinstance(speech, Recorded)
    model_dir, chosen = check(settings, recorded=recorded, dub=dub)
    inputs = (*inputs, *((speech.audio, speech.timings) if recorded else ()))
    output = check_output(output, overwrite=settings.overwrite, inputs=inputs)
    return Checked(output, model_dir, chosen, inputs, settings.overwrite)


@contextlib.contextmanager
def started(speech: Speech, settings: SpeechSettings) -> Iterator[Recorded | PendingSpeech]:
    """A recording as it is; typed text with Festival started on it (closed on the way out,
    if :func:`miketalk.talk.say.say` did not finish it)."""
    if isinstance(speech, Recorded):
        yield speech
        return
    from miketalk.speech import get_backend

    backend = get_backend("festival", voice=settings.voice or DEFAULT_VOICE)
    with backend.start_sentences(speech) as pending:
        log.info("Festival started (%s voice)", settings.voice or DEFAULT_VOICE)
        yield pending


def say(
    speech: Speech,
    output: str | os.PathLike[str] | int,
    settings: SaySettings | None = None,
    *,
    models: OpenModels | None = None,
    progress: bool = False,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> SayResult:
    """Make the model's face say ``speech``: an mp4 at ``output``, its timeline JSON beside it;
    or a fragmented MP4 on a file descriptor.

    :func:`say_stream` read by a writer (:mod:`miketalk.talk.publish`).

    Parameters
    ----------
    speech : str or Recorded
        Typed text (Festival speaks it), or a recording and what it says.
    output : path-like or int
        The ``.mp4`` to write (``NAME.json`` beside it); the two replace an older pair
        together or not at all. An int: a file descriptor (a pipe) the utterance is written
        on as a fragmented MP4 as it is made (no JSON; ``miketalk say ... -o -``).
    settings : SaySettings, optional
        The model, how its mouth moves, the frame rate, the voice, the background.
    models : OpenModels, optional
        Models kept open between calls (the page's); None: the model is opened and closed.
    progress : bool
        Draw progress bars on stderr.
    inputs : sequence of path-like
        Files the caller read for this (a text file): never written over.

    Returns
    -------
    SayResult

    Raises
    ------
    MiketalkError
        In one line, before the work where it can be (:func:`check`, the output).
    """
    settings = settings if settings is not None else SaySettings()
    if isinstance(output, int):
        stream = say_stream(speech, settings, models=models, progress=progress)
        return said_result(speech, settings, write(stream, output))
    plan = checked(speech, output, settings, inputs=inputs)
    stream = _stream(speech, settings, plan.model_dir, plan.lipsync_model, models, progress)
    return said_result(speech, settings, write(stream, plan.output, plan))


def say_stream(
    speech: Speech,
    settings: SaySettings | None = None,
    *,
    models: OpenModels | None = None,
    progress: bool = False,
) -> Stream:
    """The model's face saying ``speech``, as a stream of timed chunks (docs/api.md).

    The stream (:class:`~miketalk.talk.stream.Stream`) starts when it is entered or read:
    ``stream.info()`` gives the frame rate and the sound's sample rate, iterating it gives
    each frame with the samples played while it shows, in order; the engine waits while
    the reader is behind (at most :data:`~miketalk.talk.stream.QUEUE_CHUNKS` frames held),
    and ``stream.cancel()``, from any thread, ends the work and every process it started.

    Raises
    ------
    MiketalkError
        In one line, at once: :func:`check`'s. The engine's (nothing speakable, a failing
        Festival) are raised to the stream's reader.
    """
    settings = settings if settings is not None else SaySettings()
    model_dir, chosen = check(settings, recorded=isinstance(speech, Recorded))
    return _stream(speech, settings, model_dir, chosen, models, progress)


def _stream(
    speech: Speech,
    settings: SaySettings,
    model_dir: Path,
    lipsync_model: LipsyncModel,
    models: OpenModels | None,
    progress: bool,
) -> Stream:
    """:func:`say_stream` once checked."""
    from miketalk.talk.stream import Stream

    def produce(emitter: Emitter) -> Uttered:
        with started(speech, settings) as said:
            with opened(
                model_dir, models, background=settings.background, progress=progress,
                check_person=settings.check_person,
            ) as (model, background):  # fmt: skip
                emitter.check()
                fps = settings.fps if settings.fps is not None else own_fps(model, background)
                return engine(said, settings.lipsync(fps, lipsync_model), model, background,
                              progress=progress, table=settings.table())(emitter)  # fmt: skip

    return Stream(produce, name="say")


def write(stream: Stream, output: Path | int, plan: Checked | None = None) -> Spoken:
    """``stream`` written: to the file pair ``plan`` checked (x264's file settings), or on the
    descriptor ``output`` (:func:`~miketalk.talk.publish.pipe_out`, ``-o -``: the live
    stream, x264's live settings)."""
    from miketalk.talk.publish import pipe_out, publish

    if plan is None:
        if not isinstance(output, int):
            raise TypeError("a file output is written once checked")
        return pipe_out(stream, output, live=True)
    return publish(stream, plan.output, overwrite=plan.overwrite, inputs=plan.inputs)


def write_fragmented(stream: Stream, fd: int, *, live: bool = True) -> Spoken:
    """Write a :func:`say_stream` (or :func:`~miketalk.api.dub.dub_stream`) on the file
    descriptor ``fd`` as a fragmented MP4, as it is made (what ``say -o -`` does); a
    ``stream.cancel()`` from another thread stops it, and this raises
    :class:`~miketalk.talk.stream.Cancelled`. ``live`` (``-o -`` and the page): x264's live
    settings (:data:`~miketalk.media.x264.LIVE_X264`: no look-ahead, half the encoder's CPU;
    the frames then differ slightly from the file's); False: the file's
    (:data:`~miketalk.media.x264.FILE_X264`: the file's H.264 stream, fragmented).

    Returns
    -------
    Spoken
        The timeline and the motion of what was written (no files: ``video`` is None).
    """
    from miketalk.talk.publish import pipe_out

    return pipe_out(stream, fd, live=live)


def said_result(speech: Speech, settings: SaySettings, spoken: Spoken) -> SayResult:
    """The :class:`SayResult` of ``spoken``."""
    return SayResult(
        spoken, spoken.timeline.fps, settings.sampling, settings.step_limit,
        max_slowdown=settings.max_slowdown, **voice_of(speech, settings),
    )  # fmt: skip


def own_fps(model: Any, background: Any) -> float:
    """The frame rate a ``say`` draws at unless told: the background video's for a model that
    plays its mouth into a face crop of it (its head motion frame for frame; 29.97 stays
    29.97), else :data:`miketalk.defaults.FPS`."""
    in_crop = background is not None and model.crop is not None
    return background.fps if in_crop else defaults.FPS


def engine(speech, lipsync, model, background, *, progress: bool, table=None, aligned=None):
    """The engine's work on ``speech`` (:func:`miketalk.talk.say.producer`; ``table``: the
    phone-to-viseme table, None: the paper's; ``aligned``: a recording's alignment started
    before)."""
    from miketalk.talk.say import producer

    return producer(speech, model=model, settings=lipsync, progress=progress,
                    background=background, table=table, aligned=aligned)  # fmt: skip


def voice_of(speech: Speech, settings: SpeechSettings | DubSettings) -> dict:
    """Who spoke: Festival's ``voice``, or the recording (``audio``)."""
    if isinstance(speech, Recorded):
        return {"audio": str(speech.audio)}
    return {"voice": settings.voice or DEFAULT_VOICE}
