"""Recorded speech in: a face speaking a recording, its phones found by forced alignment.

Where :func:`miketalk.talk.say.say` has Festival make the sound of a text, a
:class:`Recorded` recording's sound is given (a wav, or any media file with an audio
stream) together with what is said, as text or as word timings (GRID ``.align``, Praat
``.TextGrid``). The phones are placed in the recording by
:func:`miketalk.speech.align.align_phones` and the video follows them
(paper §7: one keyframe per phone, the morph rate from the phone timing).

The audio is fixed, so the paper's oversampling (which lengthens phones and
speaks them again) cannot apply; motion blur (the default sampling,
:func:`miketalk.lipsync.sampling.motion_blur`) keeps the steps between morphs
under ``max_px_per_frame`` at the recording's own speed. The measures of the
motion are in the JSON beside the mp4 and in the return value.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.lipsync.sampling import motion_blur
from miketalk.lipsync.settings import LipsyncSettings, Sampling
from miketalk.lipsync.timeline import plan
from miketalk.model.face import Model
from miketalk.speech.types import Phone
from miketalk.talk.speech import Recorded
from miketalk.talk.stream import Emitter, StreamInfo
from miketalk.talk.utterance import own_frames_doc
from miketalk.visemes import VisemeTable

if TYPE_CHECKING:
    import numpy as np

    from miketalk.composite.background import Background
    from miketalk.draw.registry import Drawing
    from miketalk.speech.coverage import SpeechCoverage
    from miketalk.speech.recognize import Heard
    from miketalk.talk.frames import Uttered
    from miketalk.talk.guided import GuidedPhones

log = logging.getLogger(__name__)

#: Rate the recording is decoded at (the aligner's).
RATE = 16000

#: A recording longer than this (seconds), given as text, is aligned in pieces
#: (:func:`miketalk.speech.long_align.align_long`): the fine aligner's memory grows with
#: the audio it is given (some 10 MB a second), a piece's stays that of 12 s.
LONG_SECONDS = 30.0

_TOKEN = re.compile(r"[a-z0-9']+(?:[.\-][a-z0-9']+)*")


@dataclass(frozen=True)
class Aligned:
    """A recording with its phones placed by forced alignment.

    Attributes
    ----------
    words : tuple of str
        What is said, lower case.
    phones : tuple of Phone
        The timed phones, covering the recording.
    samples : numpy.ndarray
        The recording, mono int16 at :data:`RATE`.
    rate : int
        :data:`RATE`.
    heard : Heard or None
        When no text was given: what the recognizer heard (the words then come from it).
    left_out : tuple of str
        A text's words left out (:mod:`miketalk.talk.guided`): not placed in the recording.
    filled_by : str or None
        The recognizer whose words filled speech the text does not hold (None: none did).
    """

    words: tuple[str, ...]
    phones: tuple[Phone, ...]
    samples: np.ndarray
    rate: int
    heard: Heard | None = None
    left_out: tuple[str, ...] = ()
    filled_by: str | None = None

    @property
    def duration(self) -> float:
        """Seconds of sound."""
        return len(self.samples) / self.rate


def transcript_words(text: str) -> list[str]:
    """The words of a transcript, lower case, punctuation dropped (``"Bin blue, now!"``).

    Raises
    ------
    MiketalkError
        When ``text`` has no word in it.
    """
    words = _TOKEN.findall(text.lower())
    if not words:
        raise MiketalkError(f"no words in the transcript {text!r}")
    return words


def align_recording(
    audio: str | os.PathLike[str],
    *,
    text: str | None = None,
    timings: str | os.PathLike[str] | None = None,
    phones: str = "aligned",
) -> Aligned:
    """The phones of a recording, placed by forced alignment of what it says.

    Parameters
    ----------
    audio : path-like
        The recording (wav, mp4, mpg: anything ffmpeg reads with an audio stream).
    text : str, optional
        What is said. Without it and without ``timings`` the words are recognized
        (:func:`miketalk.speech.recognize.recognize_words`), then aligned as a given text
        is; words the aligner cannot place in the sound are left out, named in a warning.
        A text alone whose words the aligner cannot all place, or that leaves a stretch of
        speech uncovered, is a guide (:func:`miketalk.talk.guided.guided_alignment`).
    timings : path-like, optional
        Word timings of the recording (``.align`` or ``.TextGrid``); the phones
        then stay inside their words. With ``text`` as well, both must name the
        same words.
    phones : {"aligned", "recognized"}
        ``recognized``: the words are recognized even when ``text`` is given, and the text
        is compared with them (:func:`miketalk.speech.recognize.agree.warn_disagreement`).

    Raises
    ------
    MiketalkError
        Words that do not match the timings, a recording without sound, a word the
        aligner cannot place (with timings), too little of a text placed; without text,
        speech that is not English or noise.

    Warns (:func:`warn_unexplained`) when the words leave more than a quarter
    of the recording's voiced audio outside their phones, and (:func:`warn_misfit`) when
    they fit its sound badly (likely another recording's transcript).
    """
    from miketalk.media.decode import read_media_audio
    from miketalk.speech.align.phones import UnplacedWord
    from miketalk.speech.coverage import speech_coverage
    from miketalk.speech.word_timings import read_word_timings
    from miketalk.talk.guided import UNCOVERED_SECONDS, guided_alignment
    from miketalk.workers import run_in_child

    given = read_word_timings(timings) if timings is not None else None
    words = (
        transcript_words(text) if text is not None
        else [w.word.lower() for w in given] if given is not None else None
    )  # fmt: skip
    if given is not None and [w.word.lower() for w in given] != words:
        raise MiketalkError(
            f"the word timings ({' '.join(w.word for w in given)}) do not match the text "
            f"({' '.join(words or ())})"
        )
    samples = read_media_audio(audio, rate=RATE)
    if len(samples) == 0 or not samples.any():
        raise MiketalkError(f"{audio} has no sound")
    heard = None
    if words is None or phones == "recognized":
        from miketalk.speech.recognize import recognize_words
        from miketalk.speech.recognize.agree import warn_disagreement

        # here, not in a forked child: CTranslate2's threads do not survive a fork (a child
        # of a process that has loaded it hangs); its calls return to Python at least every
        # 30 s of sound, so Ctrl-C still stops it
        recognized = recognize_words(samples, RATE, audio)
        if words is not None:
            warn_disagreement(audio, words, recognized.words)
        words, heard, given = list(recognized.words), recognized.heard, None
    log.info("aligning %d words to %.1f s of %s", len(words), len(samples) / RATE, audio)
    # a text alone, short: a guide, if it must be (a long one's unplaced words are left out)
    guide = heard is None and given is None and len(samples) <= LONG_SECONDS * RATE
    # in a child process: the aligner holds the interpreter for as long as its audio, and
    # Ctrl-C or SIGTERM must stop it at once (miketalk.workers.run_in_child)
    try:
        phones, score = run_in_child(place_phones, audio, samples, words, given, heard is not None)
    except UnplacedWord as err:
        if not guide:
            raise
        return _guided(audio, samples, guided_alignment(audio, samples, RATE, words, unplaced=err))
    coverage = speech_coverage(samples, RATE, phones)
    if guide and coverage.longest_unexplained >= UNCOVERED_SECONDS:
        found = guided_alignment(audio, samples, RATE, words, phones=(phones, score, coverage))
        return _guided(audio, samples, found)
    warn_misfit(audio, score, words)
    warn_unexplained(audio, coverage, words)
    return Aligned(tuple(words), tuple(phones), samples, RATE, heard)


def _guided(audio: object, samples: np.ndarray, found: GuidedPhones) -> Aligned:
    """A recording aligned with its text as a guide, its fit warned about as a text's."""
    warn_misfit(audio, found.score, found.words)
    if found.coverage is not None:  # the text's own alignment, kept
        warn_unexplained(audio, found.coverage, found.words)
    return Aligned(
        found.words, found.phones, samples, RATE, left_out=found.left_out,
        filled_by=found.filled_by,
    )  # fmt: skip


def place_phones(
    audio: object,
    samples: np.ndarray,
    words: list[str],
    given: Sequence | None,
    recognized: bool = False,
) -> tuple[tuple[Phone, ...], float | None]:
    """The phones of ``words`` in the recording and the words' fit (None: not measured).

    ``recognized`` words the aligner cannot place (a recognizer's mistake) are left out
    by the long recordings' aligner, which names them, rather than refused."""
    from miketalk.speech.align.phones import align

    if given is None and len(samples) > LONG_SECONDS * RATE:
        return _align_long(audio, samples, words), None
    try:
        alignment = align(samples, RATE, words, word_timings=given)
    except MiketalkError:
        if not recognized:
            raise
        return _align_long(audio, samples, words), None
    return alignment.phones, alignment.score_per_frame


def _align_long(audio: object, samples: np.ndarray, words: list[str]) -> tuple[Phone, ...]:
    """The phones of a recording longer than :data:`LONG_SECONDS`, aligned in pieces
    (:func:`miketalk.speech.long_align.align_long`: memory by the piece, not the recording);
    the words it cannot place are warned about, and the mouth rests over them.

    Raises
    ------
    MiketalkError
        When no word can be placed.
    """
    from miketalk.corpus.script import Cue
    from miketalk.speech.long_align import align_long

    found = align_long(samples, RATE, [Cue(tuple(words), start=None, end=None)])
    if not found.words:
        raise MiketalkError(f"none of the {len(words)} words could be placed in {audio}")
    if found.unaligned:
        first = found.unaligned[0]
        log.warning(
            "%s: %d of its %d words could not be placed (the first, word %d %r: %s); the "
            "mouth rests there: does the text say what the recording says?",
            audio, len(found.unaligned), len(words), first.index + 1, first.word, first.why,
        )  # fmt: skip
    return found.phones


def warn_misfit(audio: object, score: float | None, words: Sequence[str]) -> None:
    """Warn when the aligned words fit the recording's sound badly (their acoustic score per
    frame under :data:`~miketalk.speech.align.phones.FIT_LIMIT`): likely another recording's
    transcript. A warning, not a refusal: measured on GRID, right and wrong transcripts'
    scores overlap (3 % of right ones fall under the limit)."""
    from miketalk.speech.align.phones import FIT_LIMIT

    if score is None or score >= FIT_LIMIT:
        return
    said = " ".join(words)
    log.warning(
        "%s: the words fit its sound badly (%.1f per frame, under %.0f): is the text "
        "(%s) what this recording says?",
        audio, score, FIT_LIMIT, said if len(said) <= 60 else said[:57] + "...",
    )  # fmt: skip


def warn_unexplained(audio: object, coverage: SpeechCoverage, words: Sequence[str]) -> None:
    """Warn (logging, so on stderr) when the aligned words leave much of the speech unexplained.

    A warning, not a refusal: the voiced audio is found by its loudness
    (:mod:`miketalk.speech.coverage`), which cannot tell speech from a cough,
    laughter or music under the voice, and such a recording with a right
    transcript must still be usable.
    """
    from miketalk.speech.coverage import UNEXPLAINED_LIMIT

    if not coverage.mismatch:
        return
    said = " ".join(words)
    log.warning(
        "%s: %.0f%% of its %.2f s of voiced audio lies outside the aligned words "
        "(%.2f s unexplained; more than %.0f%%): does the text (%d word%s: %s) say all "
        "that the recording says?",
        audio, 100 * coverage.unexplained_share, coverage.voiced_seconds,
        coverage.unexplained_seconds, 100 * UNEXPLAINED_LIMIT, len(words),
        "" if len(words) == 1 else "s", said if len(said) <= 60 else said[:57] + "...",
    )  # fmt: skip


def _words_from(aligned: Aligned) -> str:
    """Where a recording's words came from: the text given (and the recognizer that filled
    speech it did not hold), or the recognizer alone."""
    if aligned.heard is not None:
        return aligned.heard.recognizer
    return f"given+{aligned.filled_by}" if aligned.filled_by else "given"


def _aligned(recorded: Recorded) -> Aligned:
    """:func:`align_recording` of what ``recorded`` says."""
    return align_recording(
        recorded.audio, text=recorded.text, timings=recorded.timings, phones=recorded.phones
    )


def aligning(recorded: Recorded):
    """``recorded``'s alignment started now in a child process, on another core
    (:class:`~miketalk.workers.InChild`: a ``with`` block kills it unless its ``result()``
    was taken), or None where it must be made in this process: its words are recognized,
    or this process has loaded the recognizer (CTranslate2's threads do not survive a fork:
    a child of a process that has loaded it hangs; a text's gaps may be filled by it)."""
    import sys

    from miketalk.workers import InChild

    if recorded.phones == "recognized" or (recorded.text is None and recorded.timings is None):
        return None
    if "ctranslate2" in sys.modules or "faster_whisper" in sys.modules:
        return None
    return InChild(_aligned, recorded)


def say_recording(
    emitter: Emitter,
    recorded: Recorded,
    *,
    model: Model,
    settings: LipsyncSettings,
    drawing: Drawing,
    table: VisemeTable,
    progress: bool = False,
    background: Background | None = None,
    aligned: Callable[[], Aligned] | None = None,
) -> Uttered:
    """The stream of :func:`miketalk.talk.say.say` of a recording, once its settings are
    checked: the recording aligned to what it says, the frames drawn along its phones at its
    own timing (motion blur keeps the steps under ``max_px_per_frame``; the paper's
    lengthening cannot apply), with its own sound (:attr:`StreamInfo.sound`; the chunks carry
    it mono at :data:`RATE`). ``aligned``: the alignment, asked of it (started before, while
    the video of a dub registered: :func:`aligning`), instead of made here.

    Raises
    ------
    MiketalkError
        The errors of :func:`align_recording`.
    """
    from miketalk.composite.background import background_doc
    from miketalk.corpus.sound_lag import led, model_sound_lag
    from miketalk.lipsync.motion import JerkMeter
    from miketalk.speech.acoustic import Recording
    from miketalk.talk.frames import Uttered, draw_utterance, measured, mouth_compositing

    max_px_per_frame = settings.max_px_per_frame
    # where each frame puts the mouth, found while a child aligns the recording (a dub's)
    compositing = mouth_compositing(model, background) if aligned is not None else None
    aligned = aligned() if aligned is not None else _aligned(recorded)
    emitter.check()
    lead = model_sound_lag(model.directory)  # his mouth leads his sound that much
    phones, heard = led(aligned.phones, aligned.samples, aligned.rate, lead, aligned.duration)
    timeline = plan(phones, table, fps=settings.fps, duration=aligned.duration)
    if max_px_per_frame is not None and settings.sampling == Sampling.BLUR:
        timeline = motion_blur(
            timeline, displacement=model.displacement, max_px_per_frame=max_px_per_frame
        )
    emitter.info(
        StreamInfo(
            fps=timeline.fps,
            rate=aligned.rate,
            sound=Path(recorded.audio),
            frames=len(timeline.frames),
        )
    )
    if compositing is None:
        compositing = mouth_compositing(model, background)
    jerk = JerkMeter(compositing.region if compositing is not None else None)
    weights, states = draw_utterance(
        emitter,
        model=model,
        timeline=timeline,
        samples=aligned.samples,
        rate=aligned.rate,
        drawing=drawing,
        recording=Recording(heard, aligned.rate),
        progress=progress,
        background=background,
        max_px_per_frame=max_px_per_frame,
        jerk=jerk,
        compositing=compositing,
    )
    motion = measured(
        timeline, model, drawing, natural_duration=aligned.duration, jerk=jerk,
        weights=weights, states=states,
    )  # fmt: skip
    extra = {
        "text": " ".join(aligned.words),
        "words_from": _words_from(aligned),
        "phones": recorded.phones,
        "audio": str(recorded.audio),
        "sampling": settings.sampling.value if max_px_per_frame is not None else "none",
        "max_px_per_frame": max_px_per_frame,
        "max_slowdown": None,
        "lipsync_model": drawing.lipsync_model.value,
        "sound_lag_s": lead,
    }
    extra |= {"words_left_out": " ".join(aligned.left_out)} if aligned.left_out else {}
    extra |= (own_frames_doc(drawing) if drawing.own_frames else {}) | background_doc(background)
    return Uttered(
        timeline, motion, extra, words=aligned.words, duration=aligned.duration,
        lipsync_model=drawing.lipsync_model.value, trajectory=drawing.trajectory,
    )  # fmt: skip
