"""Where a long recording is halved for the coarse aligner's memory: a pause near the middle,
the words shared out by the voiced sound either side, and the first word after the cut
settled by the fine aligner (:func:`miketalk.speech.long_align.align_long`'s first pass); and
the coarse aligner's placing of a piece's words (:func:`coarse_span`)."""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.word_timings import WordTiming

log = logging.getLogger(__name__)

__all__ = ["coarse_span", "pause_near_middle", "settle_cut", "voiced_share"]


#: How far (words) the first word after a cut, and the number of words in the window after
#: it, are searched from their estimates (:func:`settle_cut`).
SETTLE_WORDS, SETTLE_SECONDS = 3, 10.0
#: The farthest the search goes, widened by :data:`SETTLE_WORDS` while the best start is at
#: its edge.
MAX_SETTLE_WORDS = 15


def settle_cut(
    samples: np.ndarray,
    rate: int,
    cut: float,
    hi: float,
    voiced: np.ndarray,
    indices: list[int],
    k: int,
    words: list[str],
) -> int:
    """The first word after ``cut`` (a pause), from its estimate ``k`` by the voiced share.

    Over minutes, the letters of the words estimate the voiced sound they fill only to a few
    words, and a half given one word too many or too few fails as a whole. So the fine
    aligner is given the sound from ``cut`` to a pause some :data:`SETTLE_SECONDS` later,
    with the words from ``k + d`` (``|d| <=`` :data:`SETTLE_WORDS`, widened up to
    :data:`MAX_SETTLE_WORDS` while the best is at the edge) that the voiced share puts there
    (give or take two), and the start that fits the sound best (the words' score per frame)
    is kept; ``k`` when none aligns. A heuristic: on an hour of GRID clips it moved two of
    three cuts, one to the right word and one a word too far (that quarter then lost 99 of
    its 1800 words), where the estimate alone lost 489.
    """
    from miketalk.speech.align.phones import align
    from miketalk.speech.coverage import HOP_SECONDS

    end = pause_near_middle(
        voiced[: int(2 * SETTLE_SECONDS / HOP_SECONDS)], cut, cut + 2 * SETTLE_SECONDS
    )
    if end is None or end >= hi:
        return k
    part = samples[round(cut * rate) : round(end * rate)]
    right = indices[k:]
    letters = np.cumsum([len(words[i]) + 2 for i in right])
    share = voiced_share(voiced, cut, end, hi)
    guess = int(np.searchsorted(letters, share * letters[-1]))
    best, best_score = k, -np.inf
    tried: set[int] = set()
    reach = SETTLE_WORDS
    while True:  # widened while the best start is at the edge of what was tried
        for d in sorted(range(-reach, reach + 1), key=abs):
            start = k + d
            if start in tried or not 1 <= start < len(indices):
                continue
            tried.add(start)
            for m in sorted(range(max(1, guess - 2), guess + 3), key=lambda n: abs(n - guess)):
                if start + m > len(indices):
                    continue
                try:
                    found = align(part, rate, [words[i] for i in indices[start : start + m]])
                except MiketalkError:
                    continue
                if found.score_per_frame is not None and found.score_per_frame > best_score:
                    best, best_score = start, found.score_per_frame
        if abs(best - k) < reach or reach >= MAX_SETTLE_WORDS:
            break
        reach += SETTLE_WORDS
    if best != k:
        log.info(
            "the cut at %.2f s starts at word %d, not %d", cut, indices[best] + 1, indices[k] + 1
        )
    return best


def voiced_share(voiced: np.ndarray, lo: float, cut: float, hi: float) -> float:
    """The share of the voiced sound of ``[lo, hi)`` (its voiced frames) before ``cut``."""
    from miketalk.speech.coverage import HOP_SECONDS

    if not voiced.any():
        return (cut - lo) / (hi - lo)
    return float(voiced[: int((cut - lo) / HOP_SECONDS)].sum() / voiced.sum())


def pause_near_middle(voiced: np.ndarray, lo: float, hi: float) -> float | None:
    """The middle of the quiet stretch nearest the middle of ``[lo, hi)`` (its voiced frames),
    or None."""
    from miketalk.speech.coverage import HOP_SECONDS

    quiet = np.flatnonzero(~voiced)
    if quiet.size == 0:
        return None
    middle = (hi - lo) / 2 / HOP_SECONDS
    best = quiet[np.argmin(np.abs(quiet - middle))]
    t = lo + best * HOP_SECONDS
    return t if lo + 0.5 < t < hi - 0.5 else None


def coarse_span(
    samples: np.ndarray, rate: int, lo: float, hi: float, words: Sequence[str]
) -> list[WordTiming]:
    """``words`` placed in ``[lo, hi)`` by the coarse aligner (recording time)."""
    from miketalk.speech.align.decoder import _LOCK, _shared_aligner, _to_pcm, coarse_word_spans
    from miketalk.speech.align.pronounce import _check_word, extra_arpabet

    clean = [_check_word(w) for w in words]
    with _LOCK:
        arpabet = extra_arpabet(clean, _shared_aligner())
    pcm = _to_pcm(samples[round(lo * rate) : round(hi * rate)], rate).tobytes()
    spans, frate = coarse_word_spans(pcm, clean, arpabet)
    if len(spans) != len(clean):
        raise MiketalkError("the coarse pass placed other words")
    return [
        WordTiming(w, lo + a / frate, lo + (b + 1) / frate)
        for w, (a, b) in zip(clean, spans, strict=True)
    ]
