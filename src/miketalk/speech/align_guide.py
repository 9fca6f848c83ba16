"""A recording's text as a guide: merged with the words a recognizer heard in it.

A text given with a recording is often approximate: a subtitle line cut longer or shorter
than its clip, a script read loosely. The forced aligner must place every word it is given
(:func:`miketalk.speech.align.align`): a word that is not said stops it, and speech the
text does not hold is left to a closed mouth. When that happens
(:func:`miketalk.talk.recorded.align_recording`), the text is merged with what the
recognizer heard (:func:`merge`): each text word is paired with a heard one where the two
sequences agree, and

- a word of the text paired with a heard word (the same, or one heard a little wrong:
  ``three`` heard ``free``, :data:`SIMILAR`) is kept, in the text's spelling: a text, where
  it fits, beats recognition;
- a run of text words between two paired ones, with no heard word there, is kept (the
  recognizer misses short words: GRID's ``at``); the aligner places it or leaves it out;
- a run of text words at the text's start (end) is left out when the recognizer heard
  speech from the recording's start (to its end) leaving under :data:`ROOM_PER_WORD` a word
  of room for them: a caption line cut longer than its clip;
- a run of heard words that the text does not hold (a lead-in, the rest of a sentence the
  caption line stops before) fills the text; where the text has other words in the same
  place, the heard ones win (they were heard there, the text's were not) unless the two runs'
  letters are alike (:func:`_alike`: ``bin blue`` heard ``bimble``), then the text's do.

The merged words are then aligned as a text is (``miketalk.talk.recorded``); what the text
lost and what was filled are named in one warning.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

#: Two words further apart than this (:func:`pair_distance`) are never paired: a text word
#: and a heard one in the same place that share under half their letters are two different
#: words (``answers`` and ``ideas``), not one heard wrong (``bimble`` for ``bin``: 0.5;
#: ``free`` for ``three``: 0.4).
SIMILAR = 0.5

#: The room (s) a word of the text needs, at the recording's start or end, beyond the
#: speech the recognizer heard; under it the text's edge words are left out. A syllable
#: lasts about 0.2 s; on the weekly addresses the caption words not in the clip have 0 s
#: (wa03's first eight) and 0.17 s (wa04's last, "struggles").
ROOM_PER_WORD = 0.25


@dataclass(frozen=True)
class HeardSpan:
    """A word the recognizer heard (as a word to align) and its span in the recording."""

    word: str
    start: float
    end: float


@dataclass(frozen=True)
class Guided:
    """The words to align, from a text and the recognizer's words.

    Attributes
    ----------
    words : tuple of str
        In order.
    text_index : tuple of int or None
        Per word: its index in the text, or None for a word filled from the recognizer's.
    left_out : tuple of (int, str)
        The text's words left out: their index in the text and the word.
    """

    words: tuple[str, ...]
    text_index: tuple[int | None, ...]
    left_out: tuple[tuple[int, str], ...]

    @classmethod
    def whole(cls, text: Sequence[str]) -> Guided:
        """The text alone, every word kept (nothing heard to merge it with)."""
        return cls(tuple(text), tuple(range(len(text))), ())

    @property
    def filled(self) -> tuple[str, ...]:
        """The words filled from the recognizer's, in order."""
        return tuple(w for w, i in zip(self.words, self.text_index, strict=True) if i is None)


def word_distance(a: str, b: str) -> float:
    """How unlike two words are: their letters' edit distance over the longer's length
    (0: the same word; 1: nothing in common)."""
    from miketalk.speech.recognize.agree import edit_distance

    return edit_distance(a, b) / max(len(a), len(b), 1)


def pair_distance(said: str, heard: str) -> float:
    """How unlike a text word and a heard word are, as a pair: their :func:`word_distance`,
    or, for a text word of 3 letters or more, shorter than the heard one, its distance from
    the heard word's start or end of its own length (a recognizer runs words together:
    ``bin blue`` heard ``bimble``, ``bin`` like ``bim``), whichever is least."""
    full = word_distance(said, heard)
    if len(said) < 3 or len(said) >= len(heard):
        return full
    n = len(said)
    return min(full, word_distance(said, heard[:n]), word_distance(said, heard[-n:]))


def pairs(text: Sequence[str], heard: Sequence[str]) -> list[tuple[int | None, int | None]]:
    """The text's and the heard words' alignment: ``(i, j)`` pairs a text word with a heard
    one, ``(i, None)`` a text word alone, ``(None, j)`` a heard word alone, in order.

    The least total cost: a pair costs twice its :func:`pair_distance` when that is at most
    :data:`SIMILAR`, else more than the two words alone (1 each); on a tie, a pair."""
    n, m = len(text), len(heard)
    cost = np.zeros((n + 1, m + 1))
    cost[:, 0], cost[0, :] = np.arange(n + 1), np.arange(m + 1)
    apart = np.array([[pair_distance(t, h) for h in heard] for t in text]).reshape(n, m)
    sub = np.where(apart <= SIMILAR, 2 * apart, 3.0)
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            cost[i, j] = min(
                cost[i - 1, j - 1] + sub[i - 1, j - 1], cost[i - 1, j] + 1, cost[i, j - 1] + 1
            )
    out: list[tuple[int | None, int | None]] = []
    i, j = n, m
    while i > 0 or j > 0:
        if i > 0 and j > 0 and cost[i, j] == cost[i - 1, j - 1] + sub[i - 1, j - 1]:
            i, j = i - 1, j - 1
            out.append((i, j))
        elif i > 0 and cost[i, j] == cost[i - 1, j] + 1:
            i -= 1
            out.append((i, None))
        else:
            j -= 1
            out.append((None, j))
    return out[::-1]


def merge(text: Sequence[str], heard: Sequence[HeardSpan], duration: float) -> Guided:
    """The words to align from ``text`` and the recognizer's ``heard`` words (the module
    docstring's rules); ``duration``: the recording's seconds.

    Parameters
    ----------
    text : sequence of str
        The given words, lower case.
    heard : sequence of HeardSpan
        The recognizer's words, lower case, in time order.
    duration : float
        The recording's length (s).
    """
    words: list[str] = []
    index: list[int | None] = []
    left_out: list[tuple[int, str]] = []
    steps = pairs(text, [h.word for h in heard])
    paired = [k for k, (i, j) in enumerate(steps) if i is not None and j is not None]
    # the runs between paired words (and before the first, after the last)
    bounds = [-1, *paired, len(steps)]
    for a, b in pairwise(bounds):
        run = steps[a + 1 : b]
        alone_text = [i for i, j in run if j is None and i is not None]
        alone_heard = [j for i, j in run if i is None and j is not None]
        alike = bool(alone_heard) and _alike(alone_text, alone_heard, text, heard)
        if alone_heard and not alike:  # heard there: the heard words fill it, the text's are out
            words += [heard[j].word for j in alone_heard]
            index += [None] * len(alone_heard)
            left_out += [(i, text[i]) for i in alone_text]
        elif not alike and not _room(a, b, steps, heard, duration, len(alone_text)):
            left_out += [(i, text[i]) for i in alone_text]
        else:  # the text's words: between paired ones, with room, or heard a little wrong
            words += [text[i] for i in alone_text]
            index += alone_text
        if b < len(steps):
            words.append(text[steps[b][0]])  # a paired word: the text's spelling
            index.append(steps[b][0])
    return Guided(tuple(words), tuple(index), tuple(sorted(left_out)))


def _alike(
    alone_text: list[int], alone_heard: list[int], text: Sequence[str], heard: Sequence[HeardSpan]
) -> bool:
    """Whether a run of text words and the run of heard words in the same place say the same
    thing: their letters' :func:`~miketalk.speech.recognize.agree.disagreement` is at most
    :data:`~miketalk.speech.recognize.agree.DISAGREEMENT_LIMIT` (the measured rule that tells
    a recording's own text from another's)."""
    from miketalk.speech.recognize.agree import DISAGREEMENT_LIMIT, disagreement

    if not alone_text:
        return False
    share = disagreement([text[i] for i in alone_text], [heard[j].word for j in alone_heard])
    return share <= DISAGREEMENT_LIMIT


def _room(
    a: int,
    b: int,
    steps: list[tuple[int | None, int | None]],
    heard: Sequence[HeardSpan],
    duration: float,
    n: int,
) -> bool:
    """Whether a run of ``n`` text words alone between steps ``a`` and ``b`` has room: an
    inner run always (the recognizer misses short words); one at the start (end) when the
    first (last) heard word leaves :data:`ROOM_PER_WORD` a word before (after) it."""
    if a >= 0 and b < len(steps):
        return True
    if not heard:
        return True
    room = heard[steps[b][1]].start if a < 0 else duration - heard[steps[a][1]].end
    return room >= ROOM_PER_WORD * n


def heard_spans(samples: np.ndarray, rate: int) -> tuple[list[HeardSpan], str]:
    """The recognizer's words in a recording (as words to align, each with its heard word's
    span) and the recognizer's name; what it heard in the same samples before is read from
    the user's cache (:mod:`miketalk.speech.recognize.kept`).

    Raises
    ------
    MiketalkError
        The recognizer not installed, or its weights not the expected ones.
    """
    from miketalk.speech.recognize import DEFAULT_RECOGNIZER, get_recognizer, spoken_words
    from miketalk.speech.recognize.kept import kept_hear

    heard = kept_hear(get_recognizer(DEFAULT_RECOGNIZER), samples, rate)
    spans = [HeardSpan(w, h.start, h.end) for h in heard.words for w in spoken_words(h.text)]
    return spans, heard.recognizer
