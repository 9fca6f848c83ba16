"""Words of a long recording placed in pieces: a first pass finds chunks, a second aligns each.

A forced aligner given minutes of audio and a whole transcript is slow and
fragile: one word that is not said (or said differently) stops it. Long-form
aligners (SAIL, Moreno et al. 1998; aeneas; Gentle) first find anchors, then
align the pieces between them. Here:

1. **First pass.** Subtitle cues are pieces already (each cue's words in its
   span, widened by :data:`CUE_MARGIN`). A plain transcript is aligned whole by
   a coarse aligner (pocketsphinx with its default beams:
   :func:`miketalk.speech.align.decoder.coarse_word_spans`, 18 s and 190 MB for
   10 minutes of speech); when that fails, a piece under
   :data:`~miketalk.speech.long_trim.TRIM_SECONDS` is tried without up to three
   words at its edges (:func:`miketalk.speech.long_trim.trim_edges`: a caption
   line longer than its cut), else (and at once when it is longer than
   :data:`COARSE_SECONDS`) it is cut at anchors: runs of words that a recogniser
   biased to the piece's words hears as the script has them
   (:mod:`miketalk.speech.long_anchor`), placed where heard, the words between
   them placed in the sound between them the same way (the recursion of Moreno et
   al.). A piece with no anchor (and every piece with ``anchors=False``, the
   aligner before anchors) is split at the pause nearest its middle and the words
   in proportion to their letters, as the voiced sound is on either side of the
   pause, and each half is aligned the same way, down to pieces of one word,
   which are then reported as unaligned; a piece with no pause to halve at keeps only
   a word at each edge, if the coarse aligner places them
   (:func:`miketalk.speech.long_trim.keep_edges`: two lines' words either side of a
   cut). A word given to the wrong side of a split is squeezed or stretched there: the
   second pass finds it and leaves its chunk out.
2. **Chunks.** The first pass's words are cut into chunks wherever two
   neighbours are :data:`~miketalk.speech.long_chunks.CHUNK_PAUSE` apart (a breath
   between phrases), and at most :data:`~miketalk.speech.long_chunks.CHUNK_SECONDS` long
   (:mod:`miketalk.speech.long_chunks`).
3. **Second pass.** Each chunk's words are aligned again in the chunk's own
   audio, with a little silence each side (where the aligner is at its best,
   see :mod:`miketalk.speech.align.phones`). A chunk that fails, or whose words
   leave more than :data:`~miketalk.speech.coverage.UNEXPLAINED_LIMIT` of its
   voiced audio unexplained, loses its words: they are reported as unaligned
   (:attr:`LongAlignment.unaligned`) and their span is left out, never forced.
   With ``fit_limit``, a chunk whose words fit the sound badly (their score per
   frame under it) loses a word at an edge if the rest then fit
   (:func:`~miketalk.speech.long_trim.edge_off`), else is halved and each half aligned
   again, down to single words (:func:`~miketalk.speech.long_trim.misfit_split`): words of
   another script, or placed where they are not said, are left out too.
4. **Fill.** Where the first pass gave a stretch the wrong sound (an anchor's rough edge,
   a trim that dropped a word said), its words are left out, or placed a few at a time,
   though each sentence aligned alone places them: each such stretch between runs of
   placed words is aligned again with the chunks either side, in the sound between the
   words placed around them, passes 1 to 3 as above
   (:func:`miketalk.speech.long_fill.fill_gaps`; ``fill=False``: without it).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech import long_anchor, long_fill, long_trim
from miketalk.speech.align.phones import SILENCE
from miketalk.speech.long_chunks import chunk_span, chunks
from miketalk.speech.long_cuts import coarse_span, pause_near_middle, settle_cut, voiced_share
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming

log = logging.getLogger(__name__)

#: The longest audio the first pass aligns whole (s): longer audio is cut at anchors first,
#: or halved at a pause (the coarse aligner holds some 19 MB a minute: 15 minutes, 290 MB).
COARSE_SECONDS = 900.0
#: A subtitle cue's words are looked for this far (s) outside its span.
CUE_MARGIN = 0.5
#: A word of the second pass whose loud frames (its 90th percentile level) are less than
#: this many dB above the chunk's quiet (10th percentile) is not said there.
SILENT_DB = 10.0
#: ... or whose phones (four or more) last this long (s) or less each: the aligner's
#: shortest phone is 30 ms, and a word that is not said gets squeezed to it.
SQUEEZED_PHONE = 0.035


@dataclass(frozen=True)
class Unaligned:
    """A word that was not placed: its index in the script, the word, and why."""

    index: int
    word: str
    why: str


@dataclass(frozen=True)
class LongAlignment:
    """The words placed in a recording, and the ones that could not be.

    Attributes
    ----------
    words : tuple of (int, WordTiming)
        Each placed word's index in the script and its span (recording time), in order.
    unaligned : tuple of Unaligned
        The words left out, with why.
    chunks : tuple of (float, float, int)
        The audio span of each chunk of the second pass and how many of
        ``words`` (the next ones) it holds.
    phones : tuple of Phone
        The phones of the second pass, in recording time, contiguous from 0 to the end
        of the audio (silence as ``pau``, also between the chunks and over what was left
        out): :func:`stitch_phones` of the chunks' own.
    scores : tuple of float or None
        Each chunk's acoustic score per frame of its words in the second pass
        (:attr:`miketalk.speech.align.phones.Alignment.score_per_frame`; None when the
        aligner gave none): how well the words fit the sound.
    """

    words: tuple[tuple[int, WordTiming], ...]
    unaligned: tuple[Unaligned, ...]
    chunks: tuple[tuple[float, float, int], ...]
    phones: tuple[Phone, ...] = ()
    scores: tuple[float | None, ...] = ()


def align_long(
    samples: np.ndarray,
    rate: int,
    cues: Sequence,
    *,
    fit_limit: float | None = None,
    anchors: bool = True,
    fill: bool = True,
) -> LongAlignment:
    """Place the words of ``cues`` (:class:`miketalk.corpus.script.Cue`) in a long recording.

    Parameters
    ----------
    samples : numpy.ndarray
        Mono int16 audio.
    rate : int
        Its sample rate.
    cues : sequence of Cue
        A plain transcript (one cue without times) or subtitle cues.
    fit_limit : float, optional
        A chunk of the second pass whose words score under this per frame
        (:data:`miketalk.speech.align.phones.FIT_LIMIT`) is halved where its words
        are farthest apart, and each half aligned again, down to single words: the
        words that still fit badly are left out (unaligned). None: all are kept.
    anchors : bool
        A piece of the first pass that the coarse aligner cannot place (or too long for
        it) is cut at anchors, runs of words a recogniser hears
        (:mod:`miketalk.speech.long_anchor`), before it is halved. False: halved at once
        (the aligner before anchors).
    fill : bool
        After the second pass, each stretch of words left out (or placed only a few at a
        time) is aligned again with the chunks either side, in the sound between the words
        placed around them (:func:`miketalk.speech.long_fill.fill_gaps`), as a sentence
        alone would be; kept where more words are placed. False: the aligner before it.

    Returns
    -------
    LongAlignment
    """
    duration = len(samples) / rate
    words: list[str] = []
    pieces: list[tuple[float, float, list[int]]] = []
    for i, cue in enumerate(cues):
        first = len(words)
        words += cue.words
        indices = list(range(first, len(words)))
        if cue.start is None:
            pieces.append((0.0, duration, indices))
        else:
            lo = max(0.0, cue.start - CUE_MARGIN)
            if i > 0 and cues[i - 1].end is not None:
                lo = max(lo, min(cue.start, (cues[i - 1].end + cue.start) / 2))
            hi = min(duration, cue.end + CUE_MARGIN)
            if i + 1 < len(cues) and cues[i + 1].start is not None:
                hi = min(hi, max(cue.end, (cue.end + cues[i + 1].start) / 2))
            pieces.append((lo, hi, indices))
    unaligned: list[Unaligned] = []
    first_pass: list[tuple[int, WordTiming]] = []
    for lo, hi, indices in pieces:
        if hi - lo < 0.1:
            unaligned += [Unaligned(i, words[i], "its cue lies outside the audio") for i in indices]
            continue
        first_pass += _first_pass(samples, rate, lo, hi, indices, words, unaligned, anchors)
    parts = _second_passes(samples, rate, first_pass, (0.0, duration), words, unaligned, fit_limit)
    if fill:

        def realign(lo: float, hi: float, indices: list[int], missing: list[Unaligned]) -> list:
            again = _first_pass(samples, rate, lo, hi, indices, words, missing, anchors)
            return _second_passes(samples, rate, again, (lo, hi), words, missing, fit_limit)

        parts, unaligned = long_fill.fill_gaps(parts, unaligned, len(words), duration, realign)
    placed, chunks, phones, scores = [], [], [], []
    for (a, b), group, spans, own, score in parts:
        placed += [(i, w) for (i, _), w in zip(group, spans, strict=True)]
        chunks.append((a, b, len(group)))
        phones.append(own)
        scores.append(score)
    unaligned.sort(key=lambda u: u.index)
    for u in unaligned:
        log.info("word %d %r not aligned: %s", u.index + 1, u.word, u.why)
    stitched = stitch_phones(phones, duration)
    return LongAlignment(
        tuple(placed), tuple(unaligned), tuple(chunks), tuple(stitched), tuple(scores)
    )


def _second_passes(
    samples: np.ndarray,
    rate: int,
    first_pass: list[tuple[int, WordTiming]],
    bounds: tuple[float, float],
    words: list[str],
    unaligned: list[Unaligned],
    fit_limit: float | None,
) -> list[long_fill.Part]:
    """The first pass's words (placed inside ``bounds``) in chunks, each aligned again in its
    own audio (:func:`_fitting`): the parts, in order."""
    missing = {u.index for u in unaligned}
    parts: list[long_fill.Part] = []
    at = 0  # the chunks are consecutive runs of the first pass: where this one begins
    for group in chunks(first_pass, missing):
        span = chunk_span(first_pass, at, len(group), bounds[1], missing, bounds[0])
        at += len(group)
        parts += _fitting(samples, rate, span, group, words, unaligned, fit_limit)
    return parts


def stitch_phones(chunks: Sequence[Sequence[Phone]], duration: float) -> list[Phone]:
    """The phones of consecutive chunks (each in recording time, not overlapping) as one
    contiguous list from 0 to ``duration``: silence (``pau``) between them, never two in a
    row."""
    out: list[Phone] = []

    def put(name: str, start: float, end: float) -> None:
        if end <= start + 1e-9:
            return
        if out and out[-1].name == SILENCE and name == SILENCE:
            out[-1] = Phone(SILENCE, out[-1].start, end)
        else:
            out.append(Phone(name, start, end))

    at = 0.0
    for phones in chunks:
        for p in phones:
            start, end = max(p.start, at), min(p.end, duration)
            if start > at:
                put(SILENCE, at, start)
            put(p.name, start, end)
            at = max(at, end)
    put(SILENCE, at, duration)
    return out


def _fitting(
    samples: np.ndarray,
    rate: int,
    span: tuple[float, float],
    group: list[tuple[int, WordTiming]],
    words: list[str],
    unaligned: list[Unaligned],
    fit_limit: float | None,
) -> list[long_fill.Part]:
    """A chunk's second pass; under ``fit_limit``, its halves' (see :func:`align_long`).
    Each part: its span, its words, their spans, its phones and its score."""
    lo, hi = span
    try:
        group, spans, own, score = _second_pass(samples, rate, lo, hi, group, words, unaligned)
    except MiketalkError as err:
        why = f"the second pass failed in {lo:.2f}..{hi:.2f} s ({err})"
        reported = {u.index for u in unaligned}  # the words over silence, if it got that far
        unaligned += [Unaligned(i, words[i], why) for i, _ in group if i not in reported]
        return []
    if fit_limit is None or score is None or score >= fit_limit:
        return [(span, group, spans, own, score)]
    if len(group) == 1:
        why = (
            f"it fits the sound in {lo:.2f}..{hi:.2f} s badly ({score:.1f} per frame, "
            f"under {fit_limit:g})"
        )
        unaligned.append(Unaligned(group[0][0], words[group[0][0]], why))
        return []

    def fit(a: int, b: int) -> float | None:  # the words but a at the start, b at the end
        kept = [words[i] for i, _ in group[a : len(group) - b]]
        return _align_span(samples, rate, lo, hi, kept)[2]

    off = long_trim.edge_off(len(group), fit, fit_limit, long_trim.squeezed_edges(spans, own))
    if off is not None:  # a word not said, squeezed in at an edge
        a, b = off
        why = f"the words beside it fit {lo:.2f}..{hi:.2f} s without it ({score:.1f} with it)"
        unaligned += [Unaligned(i, words[i], why) for i, _ in group[:a] + group[len(group) - b :]]
        return _fitting(samples, rate, span, group[a : len(group) - b], words, unaligned, fit_limit)
    k = long_trim.misfit_split(spans)
    cut = (spans[k - 1].end + spans[k].start) / 2
    halves = (((lo, cut), group[:k]), ((cut, hi), group[k:]))
    return [
        part
        for half, words_of in halves
        for part in _fitting(samples, rate, half, words_of, words, unaligned, fit_limit)
    ]


class _SilentWords(MiketalkError):
    """Words the aligner put where there is no voiced sound (their positions in the chunk)."""

    def __init__(self, message: str, positions: list[int]) -> None:
        super().__init__(message)
        self.positions = positions


def _second_pass(
    samples: np.ndarray,
    rate: int,
    lo: float,
    hi: float,
    group: list[tuple[int, WordTiming]],
    words: list[str],
    unaligned: list[Unaligned],
) -> tuple[list[tuple[int, WordTiming]], list[WordTiming], list[Phone], float | None]:
    """A chunk aligned again in its own audio; a word placed over silence (a word of the
    script that is not said) is dropped, reported, and the rest aligned once more. Its
    words' spans, its phones (recording time, inside ``[lo, hi]``) and their score per
    frame."""
    try:
        return (group, *_align_span(samples, rate, lo, hi, [words[i] for i, _ in group]))
    except _SilentWords as err:
        if len(err.positions) == len(group):
            raise
        why = f"it is not said in {lo:.2f}..{hi:.2f} s (the aligner put it over silence)"
        unaligned += [Unaligned(group[k][0], words[group[k][0]], why) for k in err.positions]
        group = [g for k, g in enumerate(group) if k not in err.positions]
        return (group, *_align_span(samples, rate, lo, hi, [words[i] for i, _ in group]))


def _align_span(
    samples: np.ndarray,
    rate: int,
    lo: float,
    hi: float,
    words: Sequence[str],
) -> tuple[list[WordTiming], list[Phone], float | None]:
    """``words`` aligned in ``[lo, hi)`` of the audio, their phones, in recording time, and
    the aligner's score per frame of them.

    Raises
    ------
    MiketalkError
        The aligner cannot place them, they leave much of the span's voiced
        audio unexplained (:mod:`miketalk.speech.coverage`), or one lies over
        silence or is squeezed between the words around it (:data:`SILENT_DB`,
        :data:`SQUEEZED_PHONE`, :class:`_SilentWords`).
    """
    from miketalk.speech.align import align
    from miketalk.speech.audio_align import HOP, energy_db
    from miketalk.speech.coverage import speech_coverage

    part = samples[round(lo * rate) : round(hi * rate)]
    result = align(part, rate, words)
    coverage = speech_coverage(part, rate, result.phones)
    if coverage.mismatch and coverage.voiced_seconds > 0.5:
        raise MiketalkError(
            f"the words leave {100 * coverage.unexplained_share:.0f} % of the voiced audio "
            "unexplained"
        )
    level = energy_db(part, rate)  # every 10 ms
    floor = np.percentile(level, 10)
    silent = []
    for k, w in enumerate(result.words):
        inside = level[int(w.start / HOP) : max(int(w.start / HOP) + 1, int(w.end / HOP))]
        phones = [p for p in result.phones if w.start - 1e-6 <= p.start < w.end - 1e-6]
        squeezed = len(phones) >= 4 and w.end - w.start <= SQUEEZED_PHONE * len(phones)
        if squeezed or (inside.size and np.percentile(inside, 90) < floor + SILENT_DB):
            silent.append(k)
    if silent:
        names = ", ".join(repr(words[k]) for k in silent)
        raise _SilentWords(f"{names} would lie over silence", silent)
    spans = [WordTiming(w.word, w.start + lo, w.end + lo) for w in result.words]
    phones = [Phone(p.name, p.start + lo, p.end + lo) for p in result.phones]
    return spans, phones, result.score_per_frame


def _first_pass(
    samples: np.ndarray,
    rate: int,
    lo: float,
    hi: float,
    indices: list[int],
    words: list[str],
    unaligned: list[Unaligned],
    anchored: bool = False,
) -> list[tuple[int, WordTiming]]:
    """The words ``indices`` placed in ``[lo, hi)``: whole, else (``anchored``) between
    anchors, else halves (see the module)."""
    if not indices:
        return []
    if hi - lo <= COARSE_SECONDS:
        try:
            spans = coarse_span(samples, rate, lo, hi, [words[i] for i in indices])
            return list(zip(indices, spans, strict=True))
        except MiketalkError as err:
            failure = str(err)
        if hi - lo <= long_trim.TRIM_SECONDS and len(indices) > 1:
            piece = [words[i] for i in indices]
            place = partial(coarse_span, samples, rate, lo, hi)
            trimmed = long_trim.trim_edges(samples, rate, (lo, hi), piece, place)
            if trimmed is not None:
                a, b, spans = trimmed
                why = f"the words around it fit {lo:.2f}..{hi:.2f} s without it"
                dropped = indices[:a] + indices[len(indices) - b :]
                unaligned += [Unaligned(i, words[i], why) for i in dropped]
                return list(zip(indices[a : len(indices) - b], spans, strict=True))
    else:  # the coarse aligner's memory grows with the audio: halves first
        failure = f"longer than {COARSE_SECONDS:.0f} s"
    if anchored and len(indices) >= long_anchor.ANCHOR_WORDS:
        again = partial(_first_pass, samples, rate, words=words, unaligned=unaligned, anchored=True)
        found = long_anchor.anchored_pass(
            samples, rate, (lo, hi), indices, words, again,
            lambda gap, why: unaligned.extend(Unaligned(i, words[i], why) for i in gap),
        )  # fmt: skip
        if found is not None:
            return found
    from miketalk.speech.coverage import HOP_SECONDS, voiced_frames

    voiced = voiced_frames(samples[round(lo * rate) : round(hi * rate)], rate)
    cut = pause_near_middle(voiced, lo, hi)
    if len(indices) >= 2 and cut is None and hi - lo <= long_trim.TRIM_SECONDS:
        piece, place = [words[i] for i in indices], partial(coarse_span, samples, rate, lo, hi)
        kept = long_trim.keep_edges(samples, rate, (lo, hi), piece, place)
        if kept is not None:  # a cut between two lines: their words either side of it
            a, b, spans = kept
            why = f"the words around it fit {lo:.2f}..{hi:.2f} s without it"
            unaligned += [Unaligned(i, words[i], why) for i in indices[a : len(indices) - b]]
            return list(zip(indices[:a] + indices[len(indices) - b :], spans, strict=True))
    if len(indices) < 2 or cut is None:
        why = f"cannot be placed in {lo:.2f}..{hi:.2f} s ({failure})"
        unaligned += [Unaligned(i, words[i], why) for i in indices]
        return []
    letters = np.cumsum([len(words[i]) + 2 for i in indices])
    share = voiced_share(voiced, lo, cut, hi)
    k = int(np.clip(np.searchsorted(letters, share * letters[-1]), 1, len(indices) - 1))
    if hi - lo > COARSE_SECONDS:  # halved for its length, not for a failure: settle the cut
        after = voiced[int((cut - lo) / HOP_SECONDS) :]
        k = settle_cut(samples, rate, cut, hi, after, indices, k, words)
    return _first_pass(samples, rate, lo, cut, indices[:k], words, unaligned, anchored) + (
        _first_pass(samples, rate, cut, hi, indices[k:], words, unaligned, anchored)
    )
