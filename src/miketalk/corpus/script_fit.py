"""Whether a video's script is its own: the words that fit its sound, and how they lie.

Captions are often cut apart from their video: a caption line holds words said before or
after the cut, and a clip holds words of no line. And a transcript can be another video's.
:func:`~miketalk.corpus.one_video.segment_video` builds from the words that fit and
refuses a script of which too little does:

1. **Fit.** The long aligner keeps a chunk's words only where they fit the sound: a chunk
   scoring under :data:`~miketalk.speech.align.phones.FIT_LIMIT` per frame is halved
   down to single words (:func:`~miketalk.speech.long_align.align_long`'s ``fit_limit``).
   Without it, the aligner places most of a transcript of other GRID clips of the same
   talker (the same 51 words and grammar: 83 to 88 % of the words), as much as of the
   weekly-address captions cut apart from their clips (81 %), and the README's
   "matching" weekly-address captions, one of which is another line, whole: the share
   left out does not tell a wrong script from a cut-apart one.
2. **Stretches** (:func:`trusted`). The words that fit must come in stretches of at
   least :data:`MIN_STRETCH` consecutive words of the script; shorter ones are left out.
   This is the pattern that tells the scripts apart: other clips' words fit here and
   there, a word or a few at a time (32 to 68 of the 240 words of 40 clips in short
   stretches, at most 26 in long ones), cut-apart captions' in whole lines (1 to 14 words
   in short stretches, 56 to 227 in long ones). Where the words left out lie says
   little: after the halving, nearly all of them, for every kind of script, are in runs
   that hold a line's first or last word.
3. **Share** (:func:`judge`). Refused when the words kept are fewer than
   :data:`MIN_KEPT_SHARE` of the script *and* explain less than
   :data:`MIN_EXPLAINED_SHARE` of the voiced audio: little of the script fits the sound,
   and little of the sound is the script's. Either alone is not a wrong script: most of a
   script fitting a part of a long video, or a part of a long script saying most of it.

Measured (``python -m miketalk_lab.bench.script_fit``; the table in ``docs/build.md``):
scripts of other videos keep at most 9 % of their words, explaining at most 8 % of the
speech (the GRID clips two on in name order, which share half the words of each line, and 10
other GRID clips; the weekly addresses with GRID lines or GRID with their captions none); the
weekly-address captions cut apart from their eight clips keep 75 % (plain transcript, and a
cue per clip), explaining 72 %; GRID lines with extra words at their edges 87 % (10 clips) and
85 % (40; 84 % as cues); misheard words 93 and 92 %; right scripts 100 % (the long aligner's
last pass, :mod:`miketalk.speech.long_fill`; before it 65 to 76 % for cut-apart captions). So
30 % of either sits between the two with a margin of some 21 points below and 45 above.
Before the long aligner's anchors (:mod:`miketalk.speech.long_anchor`), GRID lines with
extra words over 40 clips in a plain transcript kept 20 % (its first pass failed throughout
when most lines hold words that are not said) and were refused.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.long_align import LongAlignment, Unaligned
from miketalk.speech.types import Phone

#: A stretch of consecutive words of the script that fit the sound (chunks of the long
#: alignment one after the other, no word of the script skipped between them) shorter than
#: this is not trusted: its words are left out.
MIN_STRETCH = 5
#: A script is refused when the words kept are fewer than this share of its words and
#: explain less than :data:`MIN_EXPLAINED_SHARE` of the voiced audio.
MIN_KEPT_SHARE = 0.3
MIN_EXPLAINED_SHARE = 0.3
#: The most words a script may hold for each second of its video: more cannot all be said
#: there, and the script is refused before the aligner starts (a 1 MB one-line transcript
#: for 18 s of video ran the aligner for more than 5 minutes). Measured (a transcript's
#: words, :func:`miketalk.corpus.script.text_words`, over its clip's seconds): s1's 200 GRID
#: clips 2.01 a second (GRID's fast six-word sentences in 3 s), the other GRID talkers 2.01,
#: the weekly addresses 2.70 to 4.93 (the most: a caption line holding words said after the
#: cut). Twice the most.
MAX_WORDS_PER_SECOND = 10.0


def check_script_length(words: int, seconds: float, name: str) -> None:
    """Refuse a script of ``words`` words for ``seconds`` of video as far too long.

    Raises
    ------
    MiketalkError
        In one line, when ``words`` is more than :data:`MAX_WORDS_PER_SECOND` a second.
    """
    most = int(MAX_WORDS_PER_SECOND * seconds)
    if words > most:
        raise MiketalkError(
            f"the script has {words} words, more than the {seconds:.1f} s of {name} can hold "
            f"(at most {MAX_WORDS_PER_SECOND:g} words a second: {most}): is it this "
            "video's, and all of it?"
        )


@dataclass(frozen=True)
class ScriptFit:
    """How a script fits a recording's sound (:func:`measure_fit`).

    Attributes
    ----------
    words : int
        The script's words.
    kept : int
        Those placed in trusted stretches (:data:`MIN_STRETCH`).
    at_edges : int
        Of the others, the words in runs of left-out words that hold a line's first
        or last word (a line of the transcript, a subtitle cue).
    runs : int
        Runs of consecutive left-out words.
    stretches : int
        Trusted stretches.
    explained_share : float
        The share of the recording's voiced audio within the kept words' phones
        (:func:`miketalk.speech.coverage.speech_coverage`; 1 when nothing is voiced).
    """

    words: int
    kept: int
    at_edges: int
    runs: int
    stretches: int
    explained_share: float

    @property
    def kept_share(self) -> float:
        """The share of the script's words kept."""
        return self.kept / self.words if self.words else 0.0

    @property
    def left_out(self) -> int:
        """The words left out."""
        return self.words - self.kept


def trusted(found: LongAlignment, min_stretch: int = MIN_STRETCH) -> LongAlignment:
    """``found`` without its stretches of fewer than ``min_stretch`` words (see the module):
    their words are unaligned, their phones silence."""
    groups: list[list[int]] = []  # chunks (their numbers) one after the other in the script
    k, last = 0, None
    firsts = []
    for number, (_, _, n) in enumerate(found.chunks):
        first, end = found.words[k][0], found.words[k + n - 1][0]
        firsts.append(k)
        k += n
        if groups and last is not None and first == last + 1:
            groups[-1].append(number)
        else:
            groups.append([number])
        last = end
    size = {c: sum(found.chunks[x][2] for x in g) for g in groups for c in g}
    drop = {c for c in size if size[c] < min_stretch}
    if not drop:
        return found
    words, chunks, scores, unaligned = [], [], [], list(found.unaligned)
    for c, chunk in enumerate(found.chunks):
        part = found.words[firsts[c] : firsts[c] + chunk[2]]
        if c in drop:
            why = (
                f"it fits the sound in {chunk[0]:.2f}..{chunk[1]:.2f} s only in a stretch of "
                f"{size[c]} word{'s' if size[c] > 1 else ''} of the script (fewer than "
                f"{min_stretch}: not trusted)"
            )
            unaligned += [Unaligned(i, w.word, why) for i, w in part]
            continue
        words += part
        chunks.append(chunk)
        scores.append(found.scores[c] if c < len(found.scores) else None)
    spans = [found.chunks[c][:2] for c in sorted(drop)]
    phones = _silenced(found.phones, spans)
    unaligned.sort(key=lambda u: u.index)
    return replace(
        found,
        words=tuple(words),
        unaligned=tuple(unaligned),
        chunks=tuple(chunks),
        phones=tuple(phones),
        scores=tuple(scores),
    )


def _silenced(phones: Sequence[Phone], spans: Sequence[tuple[float, float]]) -> list[Phone]:
    """``phones`` with those inside ``spans`` made silence (``pau``, never two in a row)."""
    out: list[Phone] = []
    for p in phones:
        inside = any(lo - 1e-9 <= p.start and p.end <= hi + 1e-9 for lo, hi in spans)
        name = "pau" if inside else p.name
        if out and name == "pau" and out[-1].name == "pau":
            out[-1] = Phone("pau", out[-1].start, p.end)
        else:
            out.append(Phone(name, p.start, p.end))
    return out


def unaligned_runs(indices: Sequence[int]) -> list[tuple[int, int]]:
    """Runs of consecutive word indices, as ``(first, last)`` (``indices`` sorted)."""
    runs: list[tuple[int, int]] = []
    for i in indices:
        if runs and runs[-1][1] == i - 1:
            runs[-1] = (runs[-1][0], i)
        else:
            runs.append((i, i))
    return runs


def edge_runs(runs: Sequence[tuple[int, int]], lines: Sequence[int]) -> list[bool]:
    """Whether each run holds a line's first or last word (``lines``: each line's words)."""
    ends = np.cumsum(lines)
    edges = np.sort(np.concatenate([ends - np.asarray(lines), ends - 1]))
    return [bool(np.any((edges >= a) & (edges <= b))) for a, b in runs]


def line_of(lines: Sequence[int]) -> np.ndarray:
    """The line (0-based) of each word of a script of ``lines`` (each line's words)."""
    return np.repeat(np.arange(len(lines)), lines)


def measure_fit(
    found: LongAlignment, lines: Sequence[int], samples: np.ndarray, rate: int
) -> ScriptFit:
    """How the script fits: :class:`ScriptFit` of a :func:`trusted` alignment.

    Parameters
    ----------
    found : LongAlignment
        The alignment, its short stretches left out (:func:`trusted`).
    lines : sequence of int
        How many words each line of the script has (in order; they add up to its words).
    samples : numpy.ndarray
        The recording's sound.
    rate : int
        Its sample rate.
    """
    from miketalk.speech.coverage import speech_coverage

    runs = unaligned_runs([u.index for u in found.unaligned])
    edges = edge_runs(runs, lines)
    stretches = sum(
        1 for k, (i, _) in enumerate(found.words) if k == 0 or found.words[k - 1][0] != i - 1
    )
    coverage = speech_coverage(samples, rate, found.phones)
    return ScriptFit(
        words=int(sum(lines)),
        kept=len(found.words),
        at_edges=sum(b - a + 1 for (a, b), edge in zip(runs, edges, strict=True) if edge),
        runs=len(runs),
        stretches=stretches,
        explained_share=1.0 - coverage.unexplained_share,
    )


def judge(fit: ScriptFit, name: str) -> str | None:
    """Why the script is not taken for the video ``name``'s (one line), or None.

    Refused when none of its words fits, or when the words kept are fewer than
    :data:`MIN_KEPT_SHARE` of the script *and* explain less than
    :data:`MIN_EXPLAINED_SHARE` of the voiced audio (see the module).
    """
    if fit.kept == 0:
        return (
            f"none of the {fit.words} words can be aligned to the sound of {name}: it has no "
            "speech (music?), or the transcript is another video's"
        )
    if fit.kept_share < MIN_KEPT_SHARE and fit.explained_share < MIN_EXPLAINED_SHARE:
        return (
            f"only {fit.kept} of the {fit.words} words ({100 * fit.kept_share:.0f} %) fit the "
            f"sound of {name} in stretches of {MIN_STRETCH} or more, explaining "
            f"{100 * fit.explained_share:.0f} % of its speech (at least "
            f"{100 * MIN_KEPT_SHARE:.0f} % of either is needed): is the transcript this video's?"
        )
    return None


def where(unaligned: Sequence[Unaligned], lines: Sequence[int], *, most: int = 6) -> str:
    """Which lines hold the words left out: ``"lines 1 (11 words), 3 (8), 4 (3)"``, the
    first ``most`` of them (and how many more)."""
    line = line_of(lines)
    counts: dict[int, int] = {}
    for u in unaligned:
        counts[int(line[u.index]) + 1] = counts.get(int(line[u.index]) + 1, 0) + 1
    shown = [f"{n} ({c})" for n, c in sorted(counts.items())[:most]]
    first = sorted(counts.items())[0][1]
    shown[0] = shown[0][:-1] + (" words)" if first > 1 else " word)")
    more = f" and {len(counts) - most} more" if len(counts) > most else ""
    return f"line{'s' if len(counts) > 1 else ''} {', '.join(shown)}{more}"
