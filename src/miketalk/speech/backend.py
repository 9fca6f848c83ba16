"""The speech back-end interface and its registry."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.speech.types import Phone, Utterance

if TYPE_CHECKING:  # numpy loads later: `miketalk say` starts Festival first
    import numpy as np

#: Given an utterance's predicted phones, the phone durations (s) to speak them
#: with instead, or None to keep them.
Retime = Callable[[tuple[Phone, ...]], "Sequence[float] | np.ndarray | None"]


class PendingSpeech:
    """A synthesis started by :meth:`SpeechBackend.start`, waiting for its durations.

    :meth:`finish` it once, or :meth:`close` it to abandon it (as a context
    manager it is closed on leaving, whatever happened). This base class starts
    nothing: :meth:`finish` calls :meth:`SpeechBackend.synthesize_retimed`. An
    engine that can predict the phones while its caller does other work (load
    a model) overrides both.
    """

    def __init__(self, backend: SpeechBackend, text: str) -> None:
        self.backend = backend
        self.text = text

    def finish(self, retime: Retime) -> Utterance:
        """The utterance, spoken with the phone durations ``retime`` dictates.

        See :meth:`SpeechBackend.synthesize_retimed`.
        """
        return self.backend.synthesize_retimed(self.text, retime)

    def sentences(self) -> Iterator[PendingSpeech]:
        """The text's sentences, each to be finished in order (an engine that speaks a
        sentence while its caller uses the one before overrides it); here, the whole."""
        yield self

    def close(self) -> None:
        """Stop the engine if it still runs and remove its files (idempotent)."""

    def __enter__(self) -> PendingSpeech:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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

    def synthesize_each(self, texts: Sequence[str]) -> list[Utterance]:
        """Speak each of ``texts`` as its own utterance (an engine may batch them in one run)."""
        return [self.synthesize(text) for text in texts]

    @abstractmethod
    def resynthesize(self, utterance: Utterance, durations: Sequence[float]) -> Utterance:
        """Speak ``utterance`` again with each phone lasting ``durations[i]`` seconds.

        The returned phones follow the dictated durations exactly and the wav
        ends at the last phone's end, so that video timed from the durations
        stays in sync with the sound (paper §7).
        """

    def start(self, text: str) -> PendingSpeech:
        """Start speaking ``text``; :meth:`PendingSpeech.finish` dictates the durations later.

        ``with backend.start(text) as speech: ...; speech.finish(retime)`` is
        :meth:`synthesize_retimed`, with the caller's work between the two
        calls overlapping the engine's text analysis where the engine can.

        Raises
        ------
        MiketalkError
            Nothing speakable in ``text`` (the engine may also report it later,
            from :meth:`PendingSpeech.finish`).
        """
        return PendingSpeech(self, text)

    def start_sentences(self, text: str) -> PendingSpeech:
        """Start speaking ``text`` sentence by sentence (:meth:`PendingSpeech.sentences`);
        this default: :meth:`start`, the whole as one."""
        return self.start(text)

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
