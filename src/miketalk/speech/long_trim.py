"""What the long aligner (:func:`miketalk.speech.long_align.align_long`) does with words that
do not fit: a piece of its first pass whose words the coarse aligner cannot place is tried
without a few words at its edges (:func:`trim_edges`: a caption line longer than its cut);
a chunk of its second pass whose words fit the sound badly is halved where its words are
farthest apart (:func:`misfit_split`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.word_timings import WordTiming

__all__ = ["MAX_TRIM", "TRIM_SECONDS", "misfit_split", "trim_edges"]

#: A piece of the first pass at most this long (s) that fails is tried without up to
#: :data:`MAX_TRIM` words at its start and its end before it is halved.
TRIM_SECONDS = 8.0
MAX_TRIM = 3


def trim_edges(
    samples: np.ndarray,
    rate: int,
    span: tuple[float, float],
    piece: Sequence[str],
    place: Callable[[Sequence[str]], list[WordTiming]],
    max_trim: int = MAX_TRIM,
) -> tuple[int, int, list[WordTiming]] | None:
    """The fewest words (up to ``max_trim``) off the start (``a``) and the end (``b``) of
    ``piece`` without which ``place`` (the coarse pass in ``span``) places the rest.

    Of the ways with as few words off, the one whose words the fine aligner fits best in
    ``span`` (their score per frame). Returns ``(a, b, spans)``, or None.

    On GRID clips joined and given lines with one to three words of another sentence at
    three lines in four, the words :func:`miketalk.corpus.one_video.segment_video` keeps
    rose from 30 to 57 % (10 clips; 7 to 20 % for 40) with a plain transcript, from 43 to
    74 % with sentence cues (40 clips); of the weekly-address captions cut apart from
    their clips, from 49 to 47 % in a plain transcript and from 55 to 65 % in cues
    (``python -m miketalk_lab.bench.script_fit``, with and without it).
    """
    from miketalk.speech.align.phones import align

    part = samples[round(span[0] * rate) : round(span[1] * rate)]
    for total in range(1, min(max_trim, len(piece) - 1) + 1):
        best, best_score = None, -np.inf
        for a in range(total + 1):
            kept = list(piece[a : len(piece) - (total - a)])
            try:
                spans = place(kept)
                score = align(part, rate, kept).score_per_frame
            except MiketalkError:
                continue
            score = -np.inf if score is None else score
            if best is None or score > best_score:
                best, best_score = (a, total - a, spans), score
        if best is not None:
            return best
    return None


def misfit_split(spans: Sequence[WordTiming]) -> int:
    """Where a chunk of (two or more) words that fit badly is halved: before the word, away
    from either end by a quarter of the words, after the longest gap (ties: the middle)."""
    n = len(spans)
    middle = range(max(1, n // 4), max(2, n - n // 4))
    return max(middle, key=lambda j: (spans[j].start - spans[j - 1].end, -abs(2 * j - n)))
