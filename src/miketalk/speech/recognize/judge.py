"""Whether what was heard can be spoken by an English face: the measured rule.

Measured with Whisper base (``python -m miketalk_lab.bench.recognizer``, docs/recognize.md):
ENGLISH_LIMIT and CONFIDENCE_LIMIT separate GRID s1's 200 sentences, the weekly addresses and
espeak-ng's English from espeak-ng's German and Spanish and from noise.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.speech.recognize.base import Heard, get_recognizer
from miketalk.speech.recognize.words import spoken_words

if TYPE_CHECKING:
    import numpy as np

log = logging.getLogger(__name__)

#: The recognizer miketalk uses (:mod:`miketalk.speech.recognize.whisper`).
DEFAULT_RECOGNIZER = "whisper-base"

#: With less speech than this (seconds, the voice-activity detector's), it is refused as noise.
MIN_SPEECH_SECONDS = 0.3

#: Under this probability that the speech is English, it is refused as another language.
ENGLISH_LIMIT = 0.2

#: Under this mean word confidence (or with no word), it is refused as noise.
CONFIDENCE_LIMIT = 0.45


@dataclass(frozen=True)
class Recognized:
    """A recording's recognized words, ready to align.

    Attributes
    ----------
    words : tuple of str
        The words to align (:func:`~miketalk.speech.recognize.words.spoken_words`).
    heard : Heard
        What the recognizer heard (its words, their times and confidence).
    """

    words: tuple[str, ...]
    heard: Heard


def judge(heard: Heard, source: object) -> None:
    """Refuse, in one line, what an English face cannot speak.

    Raises
    ------
    MiketalkError
        No speech (:data:`MIN_SPEECH_SECONDS`: noise), speech that is not English
        (:data:`ENGLISH_LIMIT`), or words heard too unsure to use (:data:`CONFIDENCE_LIMIT`:
        too noisy, or unclear).
    """
    if heard.speech_seconds < MIN_SPEECH_SECONDS:
        raise MiketalkError(
            f"{source}: no speech heard ({heard.speech_seconds:.1f} s of it, under "
            f"{MIN_SPEECH_SECONDS} s): noise, music or silence?"
        )
    if heard.english < ENGLISH_LIMIT:
        raise MiketalkError(
            f"{source}: the speech does not sound English (the recognizer hears "
            f"{heard.language!r}; English {heard.english:.0%}): miketalk speaks English; "
            "give the English text it says (--text) if it is English"
        )
    if heard.mean_probability < CONFIDENCE_LIMIT:
        raise MiketalkError(
            f"{source}: no speech recognized with confidence ({len(heard.words)} words, "
            f"mean confidence {heard.mean_probability:.2f} under {CONFIDENCE_LIMIT}): too "
            f"noisy or unclear to recognize{_likely(heard)}; give its text (--text)"
        )


def _likely(heard: Heard) -> str:
    """What language it sounds most like, when not English (empty when English)."""
    if heard.language == "en":
        return ""
    return f", or not English (it sounds most like {heard.language!r}; English {heard.english:.0%})"


def recognize_words(
    samples: np.ndarray, rate: int, source: object, recognizer: str = DEFAULT_RECOGNIZER
) -> Recognized:
    """The words of a recording, recognized (:func:`judge` first; what was heard in the same
    samples before is read from the user's cache, :mod:`~miketalk.speech.recognize.kept`).

    Raises
    ------
    MiketalkError
        The recognizer not installed, its weights not the expected ones; speech not
        English, or noise (:func:`judge`).
    """
    from miketalk.speech.recognize.kept import kept_hear

    heard = kept_hear(get_recognizer(recognizer), samples, rate)  # kept: the same recording
    judge(heard, source)
    words = tuple(w for word in heard.words for w in spoken_words(word.text))
    if not words:
        raise MiketalkError(f"{source}: no word recognized")
    log.info("%s: recognized %d words (%s): %s", source, len(words), heard.recognizer, heard.text)
    return Recognized(words, heard)
