"""Forced phone alignment of recorded speech with pocketsphinx, in Festival's phone set.

:func:`align_phones` places the phones of known words in a recording with
pocketsphinx 5's aligner (its US English acoustic model and CMU dictionary ship
inside the wheel: nothing is downloaded). Two passes: a word-level alignment
(``set_align_text``), then a phone-level one over the same audio
(``set_alignment``). Frames are 10 ms, so every time is a multiple of 10 ms
(until stretched onto given word timings, below).

Phone names are Festival's radio set (``voice_kal_diphone``), translated from
ARPAbet by the table ``data/arpabet_festival.tsv``. The aligner's model has no
stress, so a CMU-dictionary word's AH comes out as ``ah`` (Festival would say
``ax`` in an unstressed syllable; both are the same viseme). Words the CMU
dictionary lacks are added with a pronunciation in Festival phones, mapped to
ARPAbet through the same table; their phones keep their Festival names
(``ax``, ``el`` ...). By default Festival itself pronounces them
(:func:`festival_pronunciations`, one run of ``festival`` for all of them).

A stop or affricate that starts a word after silence keeps at most
:data:`MAX_CLOSURE` of closure: the aligner cannot tell a closure from the
silence before it and otherwise may start such a word far too early.

With word timings (from a GRID ``.align`` or a TextGrid, say), the whole
utterance is aligned as without them, then each word's phones are stretched
linearly from the aligner's span of the word onto the given span: the given
times win at word edges, the aligner places the boundaries inside the word, in
proportion, and everything outside the given words is ``pau``. (Aligning each
word's span alone was tried on GRID: pocketsphinx's aligner wants silence at
the edges of an utterance and failed on many tight word spans.)
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.align.decoder import _LOCK, _first_unplaced, _shared_aligner, _strip, _to_pcm
from miketalk.speech.align.pronounce import (
    _check_word,
    _festival_names,
    _pronunciations,
    _to_arpabet,
)
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming

#: Festival's name for silence.
SILENCE = "pau"


#: The longest closure (s) a stop or affricate keeps when it starts a word after
#: silence. Silence and a stop's closure sound alike, and the aligner often lets
#: the closure (first HMM state) of an utterance-initial P or B swallow the
#: silence before it: on GRID talker 1, "place" started at 0 s in 9 of 51 clips,
#: 0.6 s early. The excess goes back to the silence. 60 ms is a typical closure;
#: on GRID (bench/aligner.py) 40 to 100 ms put 90.4 to 91.3 % of word boundaries
#: within 50 ms of GRID's (91.3 % at 60 ms), against 90.1 % without the cap.
MAX_CLOSURE = 0.06


#: ARPAbet phones that begin with a closure.
_CLOSURE_PHONES = frozenset({"P", "B", "T", "D", "K", "G", "CH", "JH"})


@dataclass(frozen=True)
class Alignment:
    """Where the words and phones of a recording are.

    Attributes
    ----------
    words : tuple of WordTiming
        Each spoken word (lower-cased) and its span: the aligner's, or the given
        timing when word timings were given.
    phones : tuple of Phone
        Festival phone names, contiguous from 0 to the end of the audio, silence
        as ``pau`` (never two in a row).
    score_per_frame : float or None
        The aligner's acoustic score per 10 ms frame of the words (silences left out):
        how well the sound fits the words; far below :data:`FIT_LIMIT`, the words are
        likely not what the recording says. None when there were no words.
    """

    words: tuple[WordTiming, ...]
    phones: tuple[Phone, ...]
    score_per_frame: float | None = None


class UnplacedWord(MiketalkError):
    """The aligner could not place a word of the text in the recording: it is likely not
    said there (the message names it). A recording's text may then be a guide instead
    (:mod:`miketalk.speech.align_guide`)."""


#: The score per frame (:attr:`Alignment.score_per_frame`) under which a recording's words
#: likely are not what it says. On the 48 GRID clips of ``data/grid_s1`` (text only, no word
#: timings) the clips' own transcripts score -10.9 to -23.8; another clip's transcript of
#: the same length (the clip seven on, with the same grammar and often the same words) is
#: refused by the aligner for 6 clips and scores -24.1 to -61.9 for the other 42. On all 200
#: of s1's benchmark clips the two overlap: own transcripts -7.1 to -34.6 (6 under -24),
#: another clip's refused for 13 and -17.8 to -60.9 for 187 (1 at or over -24:
#: "set green in v zero now" for "set green at v four now"); no limit refuses every wrong
#: one and no right one (docs/safety.md). So under this limit the words are warned about,
#: not refused (:func:`miketalk.talk.recorded.align_recording`): 6 of the 200 right
#: transcripts are warned about, 186 of the 187 wrong ones that align.
FIT_LIMIT = -24.0


def align_phones(
    samples: np.ndarray,
    rate: int,
    words: Sequence[str],
    *,
    word_timings: Sequence[WordTiming] | None = None,
    pronounce: Callable[[str], Sequence[str]] | None = None,
) -> list[Phone]:
    """Place the phones of ``words`` in a recording.

    Parameters
    ----------
    samples : numpy.ndarray
        The audio, shape ``(n,)`` or ``(n, channels)`` (channels are averaged):
        integers on the int16 scale, or floats in [-1, 1].
    rate : int
        Sample rate in Hz; other rates than 16000 are resampled (a polyphase
        windowed-sinc filter).
    words : sequence of str
        What is said, in order: normalised words (letters, digits, apostrophes,
        periods, hyphens; any case).
    word_timings : sequence of WordTiming, optional
        Where each of ``words`` is (same words, same order): the phones of each
        word are then kept inside its span (stretched onto it from where the
        aligner put the word) and the rest is ``pau``.
    pronounce : callable, optional
        ``pronounce(word)`` -> the word's phones in Festival's radio set, for
        words the CMU dictionary lacks; by default Festival's own pronunciation
        (:func:`festival_pronunciations`).

    Returns
    -------
    list of Phone
        Festival phone names, contiguous from 0 to the end of the audio
        (``len(samples) / rate``), silence as ``pau`` (never two in a row).

    Raises
    ------
    MiketalkError
        Bad audio or settings, a word spelled with other characters, word timings
        that do not match ``words``, a word without a pronunciation, or a word the
        aligner cannot place in the audio (the message names the word).
    """
    result = align(samples, rate, words, word_timings=word_timings, pronounce=pronounce)
    return list(result.phones)


def align(
    samples: np.ndarray,
    rate: int,
    words: Sequence[str],
    *,
    word_timings: Sequence[WordTiming] | None = None,
    pronounce: Callable[[str], Sequence[str]] | None = None,
) -> Alignment:
    """Place the words and phones of ``words`` in a recording.

    As :func:`align_phones`, which returns this alignment's phones; the words'
    spans come with them.

    Returns
    -------
    Alignment
        The words (lower-cased) with their spans, and the phones.

    Raises
    ------
    MiketalkError
        As :func:`align_phones`; :class:`UnplacedWord` for a word it cannot place.
    """
    if isinstance(rate, bool) or not isinstance(rate, int | np.integer) or rate <= 0:
        raise MiketalkError(f"rate must be a positive number of Hz, got {rate!r}")
    clean = [_check_word(w) for w in words]
    duration = len(samples) / int(rate)
    timings = _check_timings(word_timings, clean, duration) if word_timings is not None else None
    pcm = _to_pcm(samples, int(rate))
    if not clean:
        return Alignment((), (Phone(SILENCE, 0.0, duration),))
    with _LOCK:
        extra = _pronunciations(clean, _shared_aligner(), pronounce)
        aligner = _shared_aligner({w: _to_arpabet(w, p) for w, p in extra.items()})
        data = pcm.tobytes()
        placed = _strip(aligner.words_placed(data, clean))
        if placed != clean:
            index = min(_first_unplaced(aligner, data, clean, placed), len(clean) - 1)
            raise UnplacedWord(
                f"cannot align the word {words[index]!r} (word {index + 1} of {len(clean)}) "
                "to the audio: is it said there?"
            )
        try:
            aligned = aligner.phone_pass(data)
            score = aligner.score_per_frame
        except RuntimeError:
            raise MiketalkError(
                f"the aligner placed the words {' '.join(clean)!r} but not their phones"
            ) from None
    frate = aligner.frate
    spans, phones = _read_alignment(aligned, frate, extra)
    if timings is not None:
        found = [WordTiming(w, g0, g1) for w, (g0, g1) in zip(clean, timings, strict=True)]
        phones = _contiguous(_stretch(spans, timings), duration)
        return Alignment(tuple(found), tuple(phones), score)
    found = [
        WordTiming(w, a0, min(a1, duration)) for w, (a0, a1, _) in zip(clean, spans, strict=True)
    ]
    slack = 1.0 / frate + aligner.window
    phones = _contiguous(phones, duration, slack=slack)
    return Alignment(tuple(found), tuple(phones), score)


_Span = tuple[float, float, list[tuple[str, float, float]]]  # a word: start, end, its phones


def _read_alignment(
    aligned: list[tuple[str, list[tuple[str, int, int, int]]]],
    frate: int,
    extra: Mapping[str, Sequence[str]],
) -> tuple[list[_Span], list[tuple[str, float, float]]]:
    """The aligner's words and phones in seconds, Festival's names, closures capped.

    ``aligned`` is :meth:`_Aligner.phone_pass`'s output; ``extra`` holds the
    Festival pronunciations of words added to the dictionary. Returns one span
    per word and every phone (silences and fillers as ``pau``).
    """
    spans: list[_Span] = []
    phones: list[tuple[str, float, float]] = []
    after_silence = True
    for name, word_phones in aligned:
        timed = [(p, a / frate, b / frate) for p, a, b, _ in word_phones]
        if name.startswith(("<", "[", "+")):
            phones += [(SILENCE, a, b) for _, a, b in timed]
            after_silence = True
            continue
        first, _, _, closure_end = word_phones[0]
        if after_silence and first in _CLOSURE_PHONES:
            cut = closure_end / frate - MAX_CLOSURE
            if cut > timed[0][1]:
                timed[0] = (first, cut, timed[0][2])
        after_silence = False
        base = re.sub(r"\(\d+\)$", "", name)
        named = _festival_names(base, timed, extra.get(base))
        spans.append((timed[0][1], timed[-1][2], named))
        phones += named
    return spans, phones


def _check_timings(
    timings: Sequence[WordTiming], words: list[str], duration: float
) -> list[tuple[float, float]]:
    if len(timings) != len(words):
        raise MiketalkError(f"{len(timings)} word timings given for {len(words)} words")
    spans = []
    previous_end = 0.0
    for timing, word in zip(timings, words, strict=True):
        if timing.word.strip().lower() != word:
            raise MiketalkError(f"word timing for {timing.word!r} given where {word!r} is said")
        start, end = float(timing.start), min(float(timing.end), duration)
        if not (math.isfinite(start) and math.isfinite(end)) or start < previous_end - 1e-9:
            raise MiketalkError(f"word timing of {word!r} overlaps the word before it")
        if not 0 <= start < end:
            raise MiketalkError(
                f"word timing of {word!r} ({timing.start:g}..{timing.end:g} s) is not "
                f"inside the audio (0..{duration:.3f} s)"
            )
        spans.append((start, end))
        previous_end = end
    return spans


def _stretch(
    spans: list[_Span],
    timings: list[tuple[float, float]],
) -> list[tuple[str, float, float]]:
    """Each word's phones mapped linearly from the aligner's span onto the given one."""
    phones: list[tuple[str, float, float]] = []
    for (a0, a1, named), (g0, g1) in zip(spans, timings, strict=True):
        scale = (g1 - g0) / (a1 - a0)
        ends = [g0 + (e - a0) * scale for _, _, e in named[:-1]] + [g1]  # exact at the edges
        phones += [(n, s, e) for (n, _, _), s, e in zip(named, [g0, *ends[:-1]], ends, strict=True)]
    return phones


def _contiguous(
    phones: list[tuple[str, float, float]], duration: float, *, slack: float = 0.0
) -> list[Phone]:
    """Phones from 0 to ``duration`` without gaps (filled with pau) or repeated pau.

    A last phone that ends less than ``slack`` before ``duration`` (the aligner's
    last, partial frame) is lengthened to it rather than followed by a pau.
    """
    out: list[list] = []

    def put(name: str, start: float, end: float) -> None:
        if end - start <= 1e-9:
            return
        if out and out[-1][0] == name == SILENCE:
            out[-1][2] = end
        else:
            out.append([name, start, end])

    t = 0.0
    for name, start, end in sorted(phones, key=lambda p: p[1]):
        start = min(max(start, t), duration)
        end = min(end, duration)
        put(SILENCE, t, start)
        put(name, start, end)
        t = max(t, end)
    if out and duration - t < slack:
        out[-1][2] = t = duration
    put(SILENCE, t, duration)
    return [Phone(name, start, end) for name, start, end in out]
