"""Recorded speech in: a face speaking a recording, its phones found by forced alignment.

Where :func:`miketalk.talk.say.say` makes the sound with Festival, here the
sound is given (a wav, or any media file with an audio stream) together with
what is said, as text or as word timings (GRID ``.align``, Praat ``.TextGrid``).
The phones are placed in the recording by
:func:`miketalk.corpus.forced_align.align_phones` and the video follows them
(paper §7: one keyframe per phone, the morph rate from the phone timing).

The audio is fixed, so oversampling (which lengthens phones and speaks them
again) cannot apply: the largest per-frame step is measured and reported
instead, in the JSON beside the mp4 and in the return value.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.talk.lipsync import Timeline, largest_step, plan
from miketalk.talk.model import Model
from miketalk.visemes import VisemeTable, default_table

#: Rate the recording is decoded at (the aligner's).
RATE = 16000

_TOKEN = re.compile(r"[a-z0-9']+(?:[.\-][a-z0-9']+)*")


@dataclass(frozen=True)
class RecordedSpeech:
    """What :func:`say_recorded` made: the words, the timeline, and the largest step."""

    words: tuple[str, ...]
    timeline: Timeline
    largest_step_px: float
    audio_seconds: float


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


def say_recorded(
    audio: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    model: Model,
    text: str | None = None,
    timings: str | os.PathLike[str] | None = None,
    fps: float = defaults.FPS,
    table: VisemeTable | None = None,
    progress: bool = False,
) -> RecordedSpeech:
    """Make the model's face speak a recording: an mp4 at ``output``, its timeline JSON beside it.

    Parameters
    ----------
    audio : path-like
        The recording (wav, mp4, mpg: anything ffmpeg reads with an audio stream).
    output : path-like
        The ``.mp4`` to write (atomically: nothing is left there on failure).
    model : Model
        The face.
    text : str, optional
        What is said. Needed unless ``timings`` is given.
    timings : path-like, optional
        Word timings of the recording (``.align`` or ``.TextGrid``); the phones
        then stay inside their words. With ``text`` as well, both must name the
        same words.
    fps : float
        Frame rate of the video.
    table : VisemeTable, optional
        Phone -> viseme (default: the paper's).
    progress : bool
        Draw a progress bar on stderr.

    Raises
    ------
    MiketalkError
        A bad output name, a recording without sound, no words, words that do
        not match the timings, a word the aligner cannot place.
    """
    from miketalk.corpus.forced_align import align_phones
    from miketalk.corpus.media_audio import read_media_audio
    from miketalk.corpus.word_timings import read_word_timings
    from miketalk.talk.say import write_utterance

    output = Path(output)
    if output.suffix.lower() != ".mp4":
        raise MiketalkError(f"output must be an .mp4 file, not {output.name!r}")
    if text is None and timings is None:
        raise MiketalkError("say what the recording says: give its text or its word timings")
    given = read_word_timings(timings) if timings is not None else None
    words = transcript_words(text) if text is not None else [w.word.lower() for w in given]
    if given is not None and [w.word.lower() for w in given] != words:
        raise MiketalkError(
            f"the word timings ({' '.join(w.word for w in given)}) do not match the text "
            f"({' '.join(words)})"
        )
    samples = read_media_audio(audio, rate=RATE)
    if len(samples) == 0 or not abs(samples.astype(int)).max() > 0:
        raise MiketalkError(f"{audio} has no sound")
    phones = align_phones(samples, RATE, words, word_timings=given)
    duration = len(samples) / RATE
    timeline = plan(phones, table or default_table(), fps, duration)
    step = largest_step(timeline, model.displacement)
    write_utterance(
        output,
        model=model,
        timeline=timeline,
        samples=samples,
        rate=RATE,
        extra={
            "text": " ".join(words),
            "audio": str(audio),
            "largest_step_px": step,
            "max_px_per_frame": None,
        },
        progress=progress,
    )
    return RecordedSpeech(tuple(words), timeline, step, duration)
