"""What the long aligner (:func:`miketalk.speech.long_align.align_long`) does with words that
do not fit: a piece of its first pass whose words the coarse aligner cannot place is tried
without a few words at its edges (:func:`trim_edges`: a caption line longer than its cut),
and one too short to halve with only a few words at its edges (:func:`keep_edges`: the
words of two lines either side of a cut); a chunk of its second pass whose words fit the
sound badly loses a word at an edge if the rest then fit (:func:`edge_off`: a word of the
script not said, squeezed in beside the words said), else is halved where its words are
farthest apart (:func:`misfit_split`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.word_timings import WordTiming

__all__ = [
    "MAX_TRIM",
    "SQUEEZED_EDGE",
    "TRIM_SECONDS",
    "edge_off",
    "keep_edges",
    "misfit_split",
    "squeezed_edges",
    "trim_edges",
]

#: A piece of the first pass at most this long (s) that fails is tried without up to
#: :data:`MAX_TRIM` words at its start and its end before it is halved.
TRIM_SECONDS = 8.0
MAX_TRIM = 3
#: A word at a chunk's edge whose phones last at most this long (s) each is squeezed: it may
#: be a word not said (:func:`edge_off`). The aligner's shortest phone is 30 ms.
SQUEEZED_EDGE = 0.04


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

    part = samples[round(span[0] * rate) : round(span[1] * rate)]
    for total in range(1, min(max_trim, len(piece) - 1) + 1):
        ways = ((a, total - a, list(piece[a : len(piece) - (total - a)])) for a in range(total + 1))
        best = _best_placed(part, rate, place, ways)
        if best is not None:
            return best
    return None


def keep_edges(
    samples: np.ndarray,
    rate: int,
    span: tuple[float, float],
    piece: Sequence[str],
    place: Callable[[Sequence[str]], list[WordTiming]],
    max_keep: int = 1,
) -> tuple[int, int, list[WordTiming]] | None:
    """The most words (up to ``max_keep`` at each edge, fewer than all) kept at the start
    (``a``) and the end (``b``) of ``piece``, the words between them left out, that
    ``place`` (the coarse pass in ``span``) places.

    For a piece of the first pass that cannot be halved (no pause in its sound) between
    two runs placed: where a caption is cut apart from its video, the end of one line is
    said before the cut and the start of the next after it, and the words between are not
    said. Of the ways with as many words kept, the one whose words the fine aligner fits
    best in ``span``. Returns ``(a, b, spans)``, or None.

    On the weekly-address captions, "for" ending one clip's line (said, 0.16 s) lay with the
    nine words of the next line that its clip does not say in 0.31 s between two anchors,
    and all ten were left out. Up to three words at each edge, other GRID clips' lines
    (10 clips) kept 10 of their 60 words, not 5: words of a wrong script placed beside a
    short run that then was five words long; one at each edge, as before.
    """

    part = samples[round(span[0] * rate) : round(span[1] * rate)]
    for total in range(min(2 * max_keep, len(piece) - 1), 0, -1):
        ways = (
            (a, total - a, [*piece[:a], *piece[len(piece) - (total - a) :]])
            for a in range(min(total, max_keep), max(-1, total - max_keep - 1), -1)
        )
        best = _best_placed(part, rate, place, ways)
        if best is not None:
            return best
    return None


def _best_placed(
    part: np.ndarray,
    rate: int,
    place: Callable[[Sequence[str]], list[WordTiming]],
    ways: Iterable[tuple[int, int, list[str]]],
) -> tuple[int, int, list[WordTiming]] | None:
    """Of the ways ``(a, b, kept words)``, the first best one whose kept words ``place``
    places and the fine aligner fits best in ``part``: ``(a, b, their spans)``, or None
    when none is placed."""
    from miketalk.speech.align.phones import align

    best, best_score = None, -np.inf
    for a, b, kept in ways:
        try:
            spans = place(kept)
            score = align(part, rate, kept).score_per_frame
        except MiketalkError:
            continue
        score = -np.inf if score is None else score
        if best is None or score > best_score:
            best, best_score = (a, b, spans), score
    return best


def edge_off(
    count: int,
    score: Callable[[int, int], float | None],
    limit: float,
    squeezed: tuple[bool, bool] = (True, True),
) -> tuple[int, int] | None:
    """The word off an edge of a chunk of ``count`` (three or more) words that fit badly
    without which the rest fit: ``(1, 0)`` (its first word off) or ``(0, 1)`` (its last),
    whichever scores better, at ``limit`` or above; None when neither does. Only an edge
    word ``squeezed`` (its first, its last) is tried: its phones last at most
    :data:`SQUEEZED_EDGE` each, as a word not said is squeezed by the aligner.

    ``score(a, b)`` is the score per frame of the chunk's words without ``a`` at the start
    and ``b`` at the end, aligned in the chunk's sound (MiketalkError: they do not align).
    A chunk of the long aligner's second pass ends at a pause or at a word left out; a word
    of the script not said (a caption's word past its cut) is squeezed in at its edge by
    the first pass. Halved instead, the chunk is cut inside its speech and its halves fit
    badly too: on 40 GRID clips joined with cues of their lines and extra words, "lay blue
    with y six now bin" scored -26.6 (limit -24), -22.7 without "bin", and its half "lay
    blue with" -44.5, so the three words said were left out ("bin": 0.033 s a phone).
    With any edge word tried (and :func:`keep_edges` keeping up to three words at each
    edge), the lines of the GRID clips two on kept 32 of their 240 words, not 27, some of
    them once a wrong line's last word (said, 0.09 s a phone) was off; tried only where
    squeezed (one word at each edge kept), 21.
    """
    if count < 3:
        return None
    best, best_score = None, limit
    for (a, b), tried in zip(((0, 1), (1, 0)), squeezed[::-1], strict=True):
        if not tried:
            continue
        try:
            found = score(a, b)
        except MiketalkError:
            continue
        if found is not None and found >= best_score:
            best, best_score = (a, b), found
    return best


def squeezed_edges(spans: Sequence[WordTiming], phones: Sequence) -> tuple[bool, bool]:
    """Whether the first and the last of ``spans`` (words, in order, with their ``phones``)
    are squeezed: their phones last at most :data:`SQUEEZED_EDGE` each."""

    def each(w: WordTiming) -> float:
        inside = sum(w.start - 1e-6 <= p.start < w.end - 1e-6 for p in phones)
        return (w.end - w.start) / max(1, inside)

    return each(spans[0]) <= SQUEEZED_EDGE, each(spans[-1]) <= SQUEEZED_EDGE


def misfit_split(spans: Sequence[WordTiming]) -> int:
    """Where a chunk of (two or more) words that fit badly is halved: before the word, away
    from either end by a quarter of the words, after the longest gap (ties: the middle)."""
    n = len(spans)
    middle = range(max(1, n // 4), max(2, n - n // 4))
    return max(middle, key=lambda j: (spans[j].start - spans[j - 1].end, -abs(2 * j - n)))
