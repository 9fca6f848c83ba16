"""Word timings of a recording: GRID ``.align`` files and Praat TextGrids.

A GRID ``.align`` file has one ``start end word`` line per word, times in units
of 1/25000 s, with ``sil`` and ``sp`` (silence, short pause) among the words. A
TextGrid is read with :mod:`praatio`: the interval tier named ``words`` (any
case), else its only interval tier; a TextGrid of several interval tiers none of which is
named ``words`` (one miketalk writes: ``phones`` and ``visemes``) is refused, not read by
its first tier (phones read as words). Silences (empty labels, and ``sil`` / ``sp``
as in GRID) are dropped, so the result holds spoken words only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

from miketalk.errors import MiketalkError

#: GRID's time unit: 1/25000 s (1000 units are one 25 fps video frame).
GRID_UNITS_PER_SECOND = 25000

#: Labels that mark silence rather than a word.
SILENCE_LABELS = frozenset({"", "sil", "sp"})


@dataclass(frozen=True)
class WordTiming:
    """One spoken word and where it is in the audio.

    Attributes
    ----------
    word : str
        The word as written in the file.
    start, end : float
        Seconds from the start of the audio; ``end > start``.
    """

    word: str
    start: float
    end: float


def read_word_timings(
    path: str | Path, *, units_per_second: int = GRID_UNITS_PER_SECOND
) -> list[WordTiming]:
    """Read the spoken words of a GRID ``.align`` file or a Praat ``.TextGrid``.

    Parameters
    ----------
    path : str or Path
        A ``.align`` file (any suffix other than ``.TextGrid`` is read as one) or
        a ``.TextGrid`` file (suffix in any case).
    units_per_second : int
        The time unit of ``.align`` files (GRID's is 1/25000 s).

    Returns
    -------
    list of WordTiming
        The words in file order; silences (``sil``, ``sp``, empty labels) dropped.

    Raises
    ------
    MiketalkError
        If the file cannot be read or is malformed (a bad line, a word that ends
        before it starts, words out of order, no interval tier); the message
        names the file.
    """
    path = Path(path)
    if path.suffix.lower() == ".textgrid":
        words = _read_textgrid(path)
    else:
        words = _read_align(path, units_per_second)
    for previous, word in pairwise(words):
        if word.start < previous.end - 1e-9:
            raise MiketalkError(
                f"{path}: word {word.word!r} at {word.start:.3f} s starts before "
                f"{previous.word!r} ends at {previous.end:.3f} s"
            )
    return words


def _read_align(path: Path, units_per_second: int) -> list[WordTiming]:
    try:
        text = path.read_text("utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise MiketalkError(f"cannot read word timings {path}: {err}") from err
    words = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        fields = line.split()
        try:
            if len(fields) != 3:
                raise ValueError
            start, end = int(fields[0]), int(fields[1])
        except ValueError:
            raise MiketalkError(
                f"{path}, line {number}: expected 'start end word' with integer times, "
                f"got {line.strip()!r}"
            ) from None
        word = fields[2]
        if word.lower() in SILENCE_LABELS:
            continue
        words.append(_timing(path, word, start / units_per_second, end / units_per_second))
    return words


def _read_textgrid(path: Path) -> list[WordTiming]:
    from praatio import textgrid  # only for TextGrids

    if not path.is_file():
        raise MiketalkError(f"cannot read word timings {path}: no such file")
    try:
        grid = textgrid.openTextgrid(str(path), includeEmptyIntervals=False)
    except Exception as err:  # praatio's parser fails in many ways on a malformed file
        raise MiketalkError(f"{path} is not a readable TextGrid: {err}") from err
    tiers = [grid.getTier(name) for name in grid.tierNames]
    intervals = [t for t in tiers if isinstance(t, textgrid.IntervalTier)]
    if not intervals:
        raise MiketalkError(f"{path} has no interval tier (of words)")
    named = [t for t in intervals if t.name.strip().lower() == "words"]
    if not named and len(intervals) > 1:
        tiers = ", ".join(t.name for t in intervals)
        raise MiketalkError(
            f"{path} has no tier named words (its interval tiers: {tiers}): name its tier of "
            "words 'words' (a TextGrid miketalk writes has phones, not words)"
        )
    tier = (named or intervals)[0]
    return [
        _timing(path, label.strip(), float(start), float(end))
        for start, end, label in tier.entries
        if label.strip().lower() not in SILENCE_LABELS
    ]


def _timing(path: Path, word: str, start: float, end: float) -> WordTiming:
    if not (math.isfinite(start) and math.isfinite(end)) or start < 0 or end <= start:
        raise MiketalkError(f"{path}: word {word!r} has bad times {start:g}..{end:g} s")
    return WordTiming(word, start, end)
