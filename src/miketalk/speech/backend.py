"""The speech back-end interface and its registry."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.types import Phone, Utterance

#: Given an utterance's predicted phones, the phone durations (s) to speak them
#: with instead, or None to keep them.
Retime = Callable[[tuple[Phone, ...]], "Sequence[float] | np.ndarray | None"]


class SpeechBackend(ABC):
    """A text-to-speech engine that reports its phones and their times."""

    name: str = ""

    @abstractmethod
    def is_available(self) -> bool:
        """Whether the engine (and its voice) can be run on this machine."""

    @abstractmethod
    def version(self) -> str:
        """The engine's version string."""

    @abstractmethod
    def synthesize(self, text: str) -> Utterance:
        """Speak ``text``: the wav and its timed phones."""

    @abstractmethod
    def resynthesize(self, utterance: Utterance, durations: Sequence[float]) -> Utterance:
        """Speak ``utterance`` again with each phone lasting ``durations[i]`` seconds.

        The returned phones follow the dictated durations exactly and the wav
        ends at the last phone's end, so that video timed from the durations
        stays in sync with the sound (paper §7).
        """

    def synthesize_retimed(self, text: str, retime: Retime) -> Utterance:
        """Speak ``text`` with the phone durations ``retime`` dictates.

        ``retime`` gets the phones the engine predicts and returns new
        durations (or None to keep them). This default speaks twice
        (:meth:`synthesize`, then :meth:`resynthesize` if durations changed);
        an engine that can stop between predicting durations and making the
        wave overrides it to speak once.
        """
        utterance = self.synthesize(text)
        durations = retime(utterance.phones)
        if durations is None:
            return utterance
        return self.resynthesize(utterance, durations)


_BACKENDS: dict[str, type[SpeechBackend]] = {}


def register(cls: type[SpeechBackend]) -> type[SpeechBackend]:
    """Class decorator: make a back-end available by its ``name``."""
    _BACKENDS[cls.name] = cls
    return cls


def get_backend(name: str = "festival", **settings: object) -> SpeechBackend:
    """Instantiate the back-end called ``name``.

    Raises
    ------
    MiketalkError
        For an unknown name.
    """
    try:
        cls = _BACKENDS[name]
    except KeyError:
        raise MiketalkError(
            f"unknown speech back-end {name!r}; known: {', '.join(sorted(_BACKENDS))}"
        ) from None
    return cls(**settings)
