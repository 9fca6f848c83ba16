"""The speech-recognizer interface, what it hears, and its registry.

A :class:`Recognizer` turns a recording into timed words with their confidence and the
language it thinks it hears. miketalk uses the words only: their phones come from its own
forced alignment (:mod:`miketalk.speech.align`), as for a text the user gives. Another
recognizer, or another source of the same weights, replaces one by registering under a name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class HeardWord:
    """One recognized word.

    Attributes
    ----------
    text : str
        As the recognizer writes it (``"F2,"``, ``"X-ray"``); see
        :func:`miketalk.speech.recognize.words.spoken_words` for the words to align.
    start, end : float
        Seconds from the start of the recording.
    probability : float
        The recognizer's confidence in the word, 0 to 1.
    """

    text: str
    start: float
    end: float
    probability: float


@dataclass(frozen=True)
class Heard:
    """What a recognizer heard in a recording.

    Attributes
    ----------
    words : tuple of HeardWord
        In time order.
    language : str
        The language it finds most likely (ISO 639-1, ``"en"``).
    english : float
        Its probability that the speech is English, 0 to 1.
    recognizer : str
        Which recognizer and weights (name and the weights' sha256, shortened).
    speech_seconds : float
        How much of the recording a voice-activity detector takes for speech.
    """

    words: tuple[HeardWord, ...]
    language: str
    english: float
    recognizer: str
    speech_seconds: float

    @property
    def text(self) -> str:
        """The words as one line."""
        return " ".join(w.text.strip() for w in self.words)

    @property
    def mean_probability(self) -> float:
        """The words' mean confidence (0 with no word)."""
        return sum(w.probability for w in self.words) / len(self.words) if self.words else 0.0


class Recognizer(ABC):
    """A speech recognizer that runs on this machine, its weights installed with miketalk."""

    name: str = ""

    @abstractmethod
    def hear(self, samples: np.ndarray, rate: int) -> Heard:
        """The words of a recording (mono int16 or float samples at ``rate`` Hz).

        Raises
        ------
        MiketalkError
            The recognizer or its weights not installed, or the weights not the ones
            expected (their checksum).
        """


_RECOGNIZERS: dict[str, type[Recognizer]] = {}


def register(cls: type[Recognizer]) -> type[Recognizer]:
    """Class decorator: make a recognizer available by its ``name``."""
    _RECOGNIZERS[cls.name] = cls
    return cls


def get_recognizer(name: str) -> Recognizer:
    """The recognizer called ``name`` (made once per process: its weights load once).

    Raises
    ------
    MiketalkError
        For an unknown name.
    """
    if name not in _MADE:
        try:
            cls = _RECOGNIZERS[name]
        except KeyError:
            raise MiketalkError(
                f"unknown speech recognizer {name!r}; known: {', '.join(sorted(_RECOGNIZERS))}"
            ) from None
        _MADE[name] = cls()
    return _MADE[name]


_MADE: dict[str, Recognizer] = {}
