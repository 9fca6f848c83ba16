"""The long aligner's chunks (:func:`miketalk.speech.long_align.align_long`, step 2): its
first pass's words cut into chunks at pauses, at words it could not place and at a length
cap, and the audio each chunk's second pass aligns."""

from __future__ import annotations

from miketalk.speech.word_timings import WordTiming

__all__ = ["CHUNK_MARGIN", "CHUNK_PAUSE", "CHUNK_SECONDS", "MISSING_MARGIN", "chunk_span", "chunks"]

#: A gap between two aligned words at least this long (s) may end a chunk.
CHUNK_PAUSE = 0.25
#: The longest chunk of the second pass (s).
CHUNK_SECONDS = 12.0
#: Audio kept each side of a chunk's words, at most (s), and half the gap to a neighbour.
CHUNK_MARGIN = 0.8
#: Audio kept on the side of a chunk where a word could not be placed (s).
MISSING_MARGIN = 0.1


def chunks(
    first_pass: list[tuple[int, WordTiming]], missing: set[int]
) -> list[list[tuple[int, WordTiming]]]:
    """The first pass's words in chunks: cut at pauses, at unaligned words, at the length cap."""
    groups: list[list[tuple[int, WordTiming]]] = []
    for i, w in first_pass:
        if groups:
            j, last = groups[-1][-1]
            gap = w.start - last.end
            skipped = any(k in missing for k in range(j + 1, i))
            long = w.end - groups[-1][0][1].start > CHUNK_SECONDS
            if gap < CHUNK_PAUSE and not skipped and not long:
                groups[-1].append((i, w))
                continue
        groups.append([(i, w)])
    return groups


def chunk_span(
    first_pass: list[tuple[int, WordTiming]],
    at: int,
    count: int,
    end: float,
    missing: set[int],
    start: float = 0.0,
) -> tuple[float, float]:
    """The audio of the chunk of ``count`` words from ``first_pass[at]``: its words with up
    to :data:`CHUNK_MARGIN` each side, never past half the gap to the neighbouring chunk's
    words, and only :data:`MISSING_MARGIN` towards a word that was not placed (its audio is
    somewhere in that gap), never outside ``[start, end]`` (the audio aligned)."""
    (i_first, first), (i_last, last) = first_pass[at], first_pass[at + count - 1]
    before = first_pass[at - 1][1].end if at > 0 else start
    after = first_pass[at + count][1].start if at + count < len(first_pass) else end
    lo = max(start, first.start - CHUNK_MARGIN, (before + first.start) / 2)
    hi = min(end, last.end + CHUNK_MARGIN, (last.end + after) / 2)
    if i_first - 1 in missing:
        lo = max(lo, first.start - MISSING_MARGIN)
    if i_last + 1 in missing:
        hi = min(hi, last.end + MISSING_MARGIN)
    return lo, hi
