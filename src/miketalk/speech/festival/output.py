"""Festival's files: the dictated ends we write, the phones, plans and waves it writes.

One chunk of text is one Festival utterance; :func:`join_chunks` makes the
:class:`~miketalk.speech.types.Utterance` of a whole text from its chunks.
"""

from __future__ import annotations

import wave
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.speech.festival.voices import Voice
from miketalk.speech.types import Phone, Utterance

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class Chunk:
    text: str
    samples: np.ndarray
    rate: int
    names: tuple[str, ...]
    ends: tuple[float, ...]


#: Tolerance, seconds, between a dictated phone end and the end Festival reports
#: (it prints times to the microsecond; a voice that ignores them is off by far more).
FOLLOW_TOLERANCE = 1e-3


def write_ends(directory: Path, index: int, ends: Sequence[float]) -> Path:
    """Chunk ``index``'s dictated Segment ends as one Scheme list of numbers."""
    path = directory / f"{index}.ends"
    path.write_text("(" + " ".join(f"{e:.6f}" for e in ends) + ")\n")
    return path


def split_ends(durations: Sequence[float], sizes: Sequence[int]) -> list[tuple[float, ...]]:
    """Split checked whole-utterance phone durations into each chunk's cumulative ends.

    ``sizes`` holds each chunk's number of phones.
    """
    import numpy as np  # here, not at the top: see the module docstring

    durations = check_durations(durations, sum(sizes))
    bounds = np.cumsum([0, *sizes])
    return [tuple(np.cumsum(durations[a:b]).tolist()) for a, b in pairwise(bounds)]


def check_same_phones(chunks: list[Chunk], names: list[str]) -> None:
    """A re-synthesis must speak the phones the durations were dictated for."""
    if [name for c in chunks for name in c.names] != names:
        raise MiketalkError("Festival produced different phones on re-synthesis")


def check_follows_durations(voice: Voice) -> None:
    """Dictated durations need a voice that speaks them (the diphone voices, not HTS)."""
    if not voice.follows_durations:
        raise MiketalkError(
            f"the {voice.name} voice sets its own phone durations, so the paper's oversampling "
            "cannot lengthen them: use sampling blur (the default) or the kal or ked voice"
        )


def check_followed(chunks: list[Chunk], ends: Sequence[Sequence[float]]) -> None:
    """Festival's phone ends must be the dictated ones (within :data:`FOLLOW_TOLERANCE`)."""
    for chunk, dictated in zip(chunks, ends, strict=True):
        worst = max(abs(a - b) for a, b in zip(chunk.ends, dictated, strict=True))
        if worst > FOLLOW_TOLERANCE:
            raise MiketalkError(
                f"Festival did not speak the dictated phone durations ({worst * 1000:.1f} ms "
                f"off in {chunk.text[:40]!r})"
            )


def check_durations(durations: Sequence[float], n: int) -> np.ndarray:
    import numpy as np  # here, not at the top: see the module docstring

    durations = np.asarray(durations, dtype=np.float64)
    if durations.shape != (n,):
        raise MiketalkError(f"{durations.size} durations given for {n} phones")
    if not np.all(np.isfinite(durations)) or np.any(durations <= 0):
        raise MiketalkError("every phone duration must be a positive number of seconds")
    return durations


def read_plan(directory: Path, index: int, text: str, rate: int) -> Chunk:
    """Chunk ``index``'s predicted phones, with silent samples as long as the phones.

    ``rate`` is the voice's sample rate, so the chunk boundaries of the
    predicted phones fall where the spoken chunks' wavs will put them.
    """
    import numpy as np  # here, not at the top: see the module docstring

    names, ends = read_phones(directory / f"{index}.plan", text)
    n = round(ends[-1] * rate)
    return Chunk(text, np.zeros(n, np.int16), rate, names, ends)


def read_phones(path: Path, text: str) -> tuple[tuple[str, ...], tuple[float, ...]]:
    if not path.exists():
        raise MiketalkError(f"Festival wrote no output for {text!r}")
    names, ends = [], []
    for line in path.read_text().splitlines():
        name, end = line.split()
        names.append(name)
        ends.append(float(end))
    if not names:
        raise MiketalkError(f"Festival returned no phones for {text!r}")
    return tuple(names), tuple(ends)


def read_chunk(directory: Path, index: int, text: str) -> Chunk:
    import numpy as np  # here, not at the top: see the module docstring

    wav_path = directory / f"{index}.wav"
    if not wav_path.exists():
        raise MiketalkError(f"Festival wrote no output for {text!r}")
    names, ends = read_phones(directory / f"{index}.phones", text)
    with wave.open(str(wav_path), "rb") as w:
        if w.getsampwidth() != 2 or w.getnchannels() != 1:
            raise MiketalkError("Festival's wav is not 16-bit mono")
        rate = w.getframerate()
        samples = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").astype(np.int16)
    # The kal voice runs ~25 ms past the last phone: cut the wav at its end (or
    # pad with silence) so that audio and phones end on the same sample.
    n = round(ends[-1] * rate)
    samples = samples[:n] if len(samples) >= n else np.pad(samples, (0, n - len(samples)))
    return Chunk(text, samples, rate, names, ends)


def join_chunks(text: str, chunks: list[Chunk]) -> Utterance:
    """Concatenate chunks; each chunk's times are offset by the samples before it."""
    import numpy as np  # here, not at the top: see the module docstring

    rate = chunks[0].rate
    phones: list[Phone] = []
    offset = 0
    start = 0.0
    for chunk in chunks:
        # a chunk's last phone ends exactly on its last sample (it moves < half a
        # sample), so the next chunk's phones start exactly where its wav does
        stops = [offset / rate + end for end in chunk.ends[:-1]]
        offset += len(chunk.samples)
        stops.append(offset / rate)
        for name, stop in zip(chunk.names, stops, strict=True):
            phones.append(Phone(name, start, stop))
            start = stop
    samples = np.concatenate([c.samples for c in chunks])
    return Utterance(
        text=text,
        samples=samples,
        rate=rate,
        phones=tuple(phones),
        chunks=tuple((c.text, len(c.names)) for c in chunks),
    )
