"""The long aligner's last pass: the words it left out aligned again where they must be.

The long aligner (:func:`miketalk.speech.long_align.align_long`) gives each stretch of the
script the sound its first pass found for it. Where that pass was wrong by a word or two (an
anchor's rough edge taking the next word's sound, a trim dropping a word said and keeping one
not said), the second pass cannot place the words in the sound it is given, or fits them
badly and halves them down to stretches too short to trust, though each sentence aligned
alone places them. On 40 GRID clips joined, with lines carrying words of another sentence,
25 words placed clip by clip were missed so, in seven places.

:func:`fill_gaps` takes each stretch of left-out words (:func:`regions`: a gap in the script,
and each run of fewer than :data:`SHORT_STRETCH` placed words), widens it by the chunk of
placed words on either side (a frame: their sound may hold a word of the stretch), and
aligns those words again, as a sentence alone is (the first pass: whole, trimmed at the
edges, at anchors; then the second pass with its fit check), in the sound between the words
placed around the frame. The new alignment replaces the old where it places more words in
runs of :data:`SHORT_STRETCH` or more (then more words), and the next stretch is taken
in the parts as they are then. Only inside :func:`zones` found before the pass: between two
runs of :data:`SHORT_STRETCH` or more placed words, at most :data:`FILL_SECONDS` of sound
apart. A script of another video fits only here and there, a few words at a time: its
zones are few and long, and it is not aligned twice (without zones, the lines of the GRID
clips two on, which share half their words, kept 23 % of their words, not 11 %).

Measured (``python -m miketalk_lab.bench.script_fit``, with and without ``--no-fill``; the
table in ``docs/build.md``): on 40 GRID lines with extra words, 247 of 300 words kept, not
227, and 9 of the words placed clip by clip missed, not 25 (3 of the 9 are words not said,
which clip-by-clip alignment forces into a clip's edge); wrong scripts keep what they kept.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from itertools import pairwise

from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming

log = logging.getLogger(__name__)

__all__ = ["FILL_SECONDS", "SHORT_STRETCH", "Part", "fill_gaps", "regions"]

#: A part of the long alignment (a chunk of its second pass): its span, its first-pass words
#: ``(index, span)``, their spans in the second pass, its phones and its score per frame.
Part = tuple[
    tuple[float, float], list[tuple[int, WordTiming]], list[WordTiming], list[Phone], float | None
]
#: Placed words in a run (chunks one after the other in the script) shorter than this are
#: aligned again with the words left out around them (as
#: :data:`miketalk.corpus.script_fit.MIN_STRETCH` does not trust them).
SHORT_STRETCH = 5
#: A stretch aligned again spans at most this much sound (s), its frame included.
FILL_SECONDS = 30.0


def fill_gaps(
    parts: Sequence[Part],
    unaligned: Sequence,
    count: int,
    duration: float,
    realign: Callable[[float, float, list[int], list], list[Part]],
) -> tuple[list[Part], list]:
    """The parts (and the words left out) with each stretch of words left out aligned again.

    Parameters
    ----------
    parts : sequence of Part
        The long alignment's chunks, in order.
    unaligned : sequence of Unaligned
        The words left out (:class:`miketalk.speech.long_align.Unaligned`).
    count : int
        The script's words.
    duration : float
        The recording's (s).
    realign : callable
        ``realign(lo, hi, indices, missing)``: the words ``indices`` of the script aligned in
        ``[lo, hi)`` of the recording as parts, the words it leaves out appended to
        ``missing``.

    Returns
    -------
    parts : list of Part
    unaligned : list of Unaligned
        Sorted by index.
    """
    parts, unaligned = list(parts), list(unaligned)
    allowed = []  # the zones' words, where the sound between them is short enough
    for s, e in zones(parts, count):
        first, end, lo, hi = _bounds(parts, s, e, count, duration)
        if hi - lo <= FILL_SECONDS:
            allowed.append((first, end))
    tried: set[tuple[int, int, float, float]] = set()
    while allowed:  # the first region not tried yet, in the parts as they are now
        for s, e in regions(parts, count):
            first, end, lo, hi = _bounds(parts, s, e, count, duration)
            if (first, end, lo, hi) in tried:
                continue
            tried.add((first, end, lo, hi))
            inside = any(a <= first and end <= b for a, b in allowed)
            whole = first == 0 and end == count  # the recording's own alignment again
            if inside and not whole and 0.1 <= hi - lo <= FILL_SECONDS:
                break
        else:
            break
        indices = list(range(first, end))
        missing: list = []
        new = realign(lo, hi, indices, missing)
        before = _placed(parts)
        after = _placed([*parts[:s], *new, *parts[e + 1 :]])
        log.debug(
            "words %d-%d in %.2f..%.2f s aligned again: %s placed, %s before",
            first + 1, end, lo, hi, after, before,
        )  # fmt: skip
        if after > before:
            parts[s : e + 1] = new
            unaligned = [u for u in unaligned if not first <= u.index < end] + missing
    unaligned.sort(key=lambda u: u.index)
    return parts, unaligned


def regions(parts: Sequence[Part], count: int) -> list[tuple[int, int]]:
    """The runs of parts aligned again (first and last part, in order, apart): each gap in
    the script between two parts (before the first, after the last) with the part either
    side, each run of parts of fewer than :data:`SHORT_STRETCH` words with the part either
    side."""
    runs, stretches = _runs(parts)
    if not runs:
        return []
    firsts, lasts = [p[1][0][0] for p in parts], [p[1][-1][0] for p in parts]
    wanted: list[tuple[int, int]] = []
    for a, b in runs:
        if a > 0 or firsts[0] > 0:  # a gap before this run
            wanted.append((max(0, a - 1), a))
        if (a, b) not in stretches:
            wanted.append((max(0, a - 1), min(len(parts) - 1, b + 1)))
    if lasts[-1] < count - 1:
        wanted.append((len(parts) - 1, len(parts) - 1))
    return sorted(set(wanted))


def zones(parts: Sequence[Part], count: int) -> list[tuple[int, int]]:
    """Where :func:`regions` may lie (first and last part): between two stretches (runs of
    at least :data:`SHORT_STRETCH` words one after the other in the script) that lie apart,
    from the last part of the one to the first of the next; before the first stretch, from
    the first part; after the last, to the last part. None without a stretch."""
    _, stretches = _runs(parts)
    if not stretches:
        return []
    firsts, lasts = [p[1][0][0] for p in parts], [p[1][-1][0] for p in parts]
    out = []
    if firsts[0] > 0 or stretches[0][0] > 0:
        out.append((0, stretches[0][0]))
    out += [(a[1], b[0]) for a, b in pairwise(stretches)]  # runs lie apart in the script
    if lasts[-1] < count - 1 or stretches[-1][1] < len(parts) - 1:
        out.append((stretches[-1][1], len(parts) - 1))
    return out


def _runs(parts: Sequence[Part]) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """The runs of parts one after the other in the script (first and last part), and those
    of them of at least :data:`SHORT_STRETCH` words."""
    firsts, lasts = [p[1][0][0] for p in parts], [p[1][-1][0] for p in parts]
    runs, at = [], 0
    for k in range(1, len(parts) + 1):
        if k == len(parts) or firsts[k] != lasts[k - 1] + 1:
            runs.append((at, k - 1))
            at = k
    stretches = [
        (a, b) for a, b in runs if sum(len(p[1]) for p in parts[a : b + 1]) >= SHORT_STRETCH
    ]
    return (runs if parts else []), stretches


def _bounds(parts: Sequence[Part], s: int, e: int, count: int, duration: float):
    """The words of parts ``s`` to ``e`` and those left out around them (first, end), and the
    sound between the words placed around them (lo, hi)."""
    lo = parts[s - 1][2][-1].end if s > 0 else 0.0
    hi = parts[e + 1][2][0].start if e + 1 < len(parts) else duration
    first = parts[s - 1][1][-1][0] + 1 if s > 0 else 0
    end = parts[e + 1][1][0][0] if e + 1 < len(parts) else count
    return first, end, lo, hi


def _placed(parts: Sequence[Part]) -> tuple[int, int]:
    """The words placed in runs of :data:`SHORT_STRETCH` or more, and all words placed."""
    total = sum(len(p[1]) for p in parts)
    trusted, run, last = 0, 0, None
    for p in parts:
        first = p[1][0][0]
        if last is not None and first != last + 1:
            trusted += run if run >= SHORT_STRETCH else 0
            run = 0
        run += len(p[1])
        last = p[1][-1][0]
    trusted += run if run >= SHORT_STRETCH else 0
    return trusted, total
