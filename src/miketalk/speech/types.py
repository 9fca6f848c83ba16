"""Timed phones and synthesized utterances."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy loads later: `miketalk say` starts Festival first
    import numpy as np


@dataclass(frozen=True)
class Phone:
    """One phone of an utterance.

    Attributes
    ----------
    name : str
        Festival's radio phone name (``"hh"``, ``"ax"``, ...); ``"pau"`` is silence.
    start, end : float
        Times in seconds from the start of the audio; ``end > start``.
    """

    name: str
    start: float
    end: float

    @property
    def duration(self) -> float:
        """``end - start`` in seconds."""
        return self.end - self.start

    @property
    def middle(self) -> float:
        """The phone's midpoint in seconds (where diphones are cut, paper §7)."""
        return 0.5 * (self.start + self.end)


@dataclass(frozen=True)
class Utterance:
    """Audio and its timed phones.

    Invariants: phones are contiguous (each starts where the previous ends, the
    first at 0) and ``len(samples) == round(phones[-1].end * rate)``: the wav ends
    exactly at the last phone's end.

    Attributes
    ----------
    text : str
        The text that was spoken (after normalisation).
    samples : numpy.ndarray
        Mono int16 samples, shape ``(n,)``.
    rate : int
        Sample rate in Hz.
    phones : tuple of Phone
        The phones in order.
    chunks : tuple of (str, int)
        How the text was spoken: each chunk's text and its number of phones
        (long text is spoken in chunks of whole sentences); re-synthesis
        speaks the same chunks again.
    """

    text: str
    samples: np.ndarray
    rate: int
    phones: tuple[Phone, ...] = field(default_factory=tuple)
    chunks: tuple[tuple[str, int], ...] = field(default_factory=tuple)

    @property
    def duration(self) -> float:
        """Length of the audio in seconds."""
        return len(self.samples) / self.rate

    def durations(self) -> list[float]:
        """Each phone's duration in seconds, in order."""
        return [p.duration for p in self.phones]

    def to_dict(self) -> dict:
        """The phones and audio facts as JSON-ready data (no samples)."""
        return {
            "text": self.text,
            "rate": self.rate,
            "n_samples": len(self.samples),
            "phones": [{"name": p.name, "start": p.start, "end": p.end} for p in self.phones],
        }
