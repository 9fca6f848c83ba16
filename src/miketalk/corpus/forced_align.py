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

import csv
import math
import os
import re
import shutil
import subprocess
import tempfile
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np

from miketalk.corpus.word_timings import WordTiming
from miketalk.errors import MiketalkError
from miketalk.speech.types import Phone

#: The aligner's sample rate (its acoustic model's).
ALIGN_RATE = 16000

#: Festival's name for silence.
SILENCE = "pau"

#: pocketsphinx settings, beside its defaults. The beams are far wider than the
#: defaults (1e-48, 1e-48, 7e-29): alignment follows one known word sequence, so a
#: wide beam costs little, and a narrow one makes the aligner give up on audio it
#: scores badly. No lattice best-path pass: it re-segments the words after the
#: alignment and can leave the phone pass a 1-frame phone it cannot align
#: (pocketsphinx warns "impossible duration ... consider disabling bestpath").
#: Word boundaries on GRID talker 1 are the same as with the defaults.
_DECODER_SETTINGS: dict[str, object] = {
    "beam": 1e-80,
    "pbeam": 1e-80,
    "wbeam": 1e-60,
    "bestpath": False,
}

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

#: Words reach Festival and pocketsphinx only if spelled with these characters
#: (the characters of the CMU dictionary's words).
_WORD = re.compile(r"[a-z0-9'.\-]+")

_FESTIVAL_HINT = "install it with: apt-get install -y festival festvox-kallpc16k"


# ---------------------------------------------------------------------------
# the ARPAbet <-> Festival table
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class ArpabetTable:
    """ARPAbet <-> Festival radio phones, read from ``data/arpabet_festival.tsv``.

    Attributes
    ----------
    to_festival : mapping of str to str
        Each ARPAbet phone (and the aligner's ``SIL`` and fillers) to one Festival phone.
    from_festival : mapping of str to tuple of str
        Each Festival radio phone to its ARPAbet spelling: one phone, two for
        Festival's syllabic consonants (``el`` -> ``AH L``), or ``SIL``.
    """

    to_festival: Mapping[str, str]
    from_festival: Mapping[str, tuple[str, ...]]


@cache
def arpabet_table() -> ArpabetTable:
    """The packaged ARPAbet <-> Festival table.

    Raises
    ------
    MiketalkError
        If the table is malformed (an unknown direction, a phone mapped twice).
    """
    text = resources.files("miketalk.data").joinpath("arpabet_festival.tsv").read_text("utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    to_festival: dict[str, str] = {}
    from_festival: dict[str, tuple[str, ...]] = {}
    for row in csv.DictReader(lines, delimiter="\t"):
        arpabet, festival, direction = row["arpabet"].split(), row["festival"], row["direction"]
        if direction not in ("both", "to_festival", "from_festival"):
            raise MiketalkError(f"arpabet_festival.tsv: unknown direction {direction!r}")
        if direction in ("both", "to_festival"):
            if len(arpabet) != 1 or arpabet[0] in to_festival:
                raise MiketalkError(f"arpabet_festival.tsv: bad to-Festival row {row}")
            to_festival[arpabet[0]] = festival
        if direction in ("both", "from_festival"):
            if festival in from_festival:
                raise MiketalkError(f"arpabet_festival.tsv: {festival!r} mapped twice")
            from_festival[festival] = tuple(arpabet)
    return ArpabetTable(to_festival, from_festival)


# ---------------------------------------------------------------------------
# Festival's pronunciations
# ---------------------------------------------------------------------------


def _check_word(word: str) -> str:
    """``word`` in lower case, or a MiketalkError naming it."""
    if not isinstance(word, str):
        raise MiketalkError(f"a word must be a string, got {word!r}")
    clean = word.strip().lower()
    if not _WORD.fullmatch(clean) or not any(ch.isalnum() for ch in clean):
        raise MiketalkError(
            f"cannot pronounce the word {word!r}: a word is letters a-z, digits, "
            "apostrophes, periods and hyphens (normalise the text first)"
        )
    return clean


_FESTIVAL_CACHE: dict[tuple[str, str], tuple[str, ...]] = {}


def festival_pronunciations(
    words: Iterable[str], *, executable: str | None = None, timeout: float = 120.0
) -> dict[str, list[str]]:
    """Festival's pronunciation of each word, in radio phones (``voice_kal_diphone``).

    One ``festival`` run looks every word up in the voice's lexicon (CMU-based),
    with Festival's letter-to-sound rules for words it lacks. The words reach
    Festival in a file named by an environment variable and are read as string
    data: they are never part of a Scheme expression or a shell command.

    Parameters
    ----------
    words : iterable of str
        Words (letters, digits, apostrophes, periods, hyphens; any case).
    executable : str, optional
        Path to ``festival``; else ``$MIKETALK_FESTIVAL``; else ``festival`` on PATH.
    timeout : float
        Seconds Festival may take.

    Returns
    -------
    dict of str to list of str
        Each distinct word, lower-cased, to its phones (e.g. ``"hello"`` ->
        ``["hh", "ax", "l", "ow"]``).

    Raises
    ------
    MiketalkError
        A word spelled with other characters, Festival missing or failing, or
        Festival giving a word no phones (the message names the word).
    """
    clean = list(dict.fromkeys(_check_word(w) for w in words))
    if not clean:
        return {}
    exe = executable or os.environ.get("MIKETALK_FESTIVAL") or "festival"
    return _run_festival_lexicon(clean, exe, timeout)


def _run_festival_lexicon(
    words: list[str], executable: str, timeout: float
) -> dict[str, list[str]]:
    path = shutil.which(executable)
    if path is None:
        raise MiketalkError(f"Festival not found ({executable!r}); {_FESTIVAL_HINT}")
    scheme = resources.files("miketalk.speech").joinpath("scheme/lexicon.scm")
    with (
        tempfile.TemporaryDirectory(prefix="miketalk-lexicon-") as tmp,
        resources.as_file(scheme) as scheme_path,
    ):
        words_file, out_file = Path(tmp, "words.scm"), Path(tmp, "pronunciations.txt")
        # the words were checked against _WORD: no quote or backslash can end a string early
        words_file.write_text("(" + " ".join(f'"{w}"' for w in words) + ")\n", "utf-8")
        env = {
            "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
            "HOME": tmp,
            "MIKETALK_WORDS": str(words_file),
            "MIKETALK_OUT": str(out_file),
        }
        command = [path, "--heap", "1000000", "-b", str(scheme_path)]
        try:
            proc = subprocess.run(
                command, env=env, cwd=tmp, capture_output=True, text=True, timeout=timeout
            )
        except subprocess.TimeoutExpired:
            raise MiketalkError(f"Festival took longer than {timeout:.0f} s") from None
        messages = (proc.stderr + proc.stdout).strip()
        if proc.returncode != 0 or "SIOD ERROR" in messages or not out_file.is_file():
            if "voice_kal_diphone" in messages and "unbound" in messages:
                raise MiketalkError(f"Festival's kal voice is missing; {_FESTIVAL_HINT}")
            tail = "\n".join(messages.splitlines()[-5:])
            raise MiketalkError(f"Festival failed (exit {proc.returncode}):\n{tail}")
        lines = out_file.read_text("utf-8").splitlines()
    if len(lines) != len(words):
        raise MiketalkError(f"Festival pronounced {len(lines)} of {len(words)} words")
    known = arpabet_table().from_festival
    result = {}
    for word, line in zip(words, lines, strict=True):
        name, _, phones = line.partition("\t")
        phones_list = phones.split()
        if name != word or not phones_list:
            raise MiketalkError(f"Festival gave no pronunciation of the word {word!r}")
        unknown = [p for p in phones_list if p not in known]
        if unknown:
            raise MiketalkError(f"Festival pronounced {word!r} with unknown phones {unknown}")
        result[word] = phones_list
    return result


# ---------------------------------------------------------------------------
# resampling
# ---------------------------------------------------------------------------


def _resample(x: np.ndarray, rate: int, target: int, *, zeros: int = 16) -> np.ndarray:
    """Resample float samples from ``rate`` to ``target`` Hz: a polyphase windowed sinc.

    The low-pass cuts at 94 % of the lower Nyquist frequency, Kaiser window
    (beta 8.6), ``zeros`` sinc zero crossings each side.
    """
    if rate == target:
        return x
    g = math.gcd(rate, target)
    up, down = target // g, rate // g
    n_out = len(x) * up // down
    cutoff = 0.94 * min(1.0, up / down)  # of the input's Nyquist frequency
    half = zeros / cutoff  # the kernel's half-width in input samples
    taps = math.ceil(half)
    offsets = np.arange(1 - taps, taps + 1, dtype=np.float64)  # k - floor(t)
    fractions = np.arange(up, dtype=np.float64)[:, None] / up  # t - floor(t), one row per phase
    tau = offsets[None, :] - fractions
    window = np.i0(8.6 * np.sqrt(np.clip(1.0 - (tau / half) ** 2, 0.0, None))) / np.i0(8.6)
    bank = np.where(np.abs(tau) <= half, cutoff * np.sinc(cutoff * tau) * window, 0.0)
    bank /= bank.sum(axis=1, keepdims=True)  # unit gain at 0 Hz in every phase
    padded = np.concatenate([np.zeros(taps), x, np.zeros(taps + 1)])
    out = np.empty(n_out, np.float64)
    block = 8192
    for first in range(0, n_out, block):
        j = np.arange(first, min(first + block, n_out), dtype=np.int64)
        base, phase = np.divmod(j * down, up)
        rows = padded[(base + 1)[:, None] + np.arange(2 * taps)[None, :]]
        out[first : first + len(j)] = np.einsum("ij,ij->i", rows, bank[phase])
    return out


def _to_pcm(samples: np.ndarray, rate: int) -> np.ndarray:
    """Mono int16 at :data:`ALIGN_RATE` from int16-scaled integers or floats in [-1, 1]."""
    samples = np.asarray(samples)
    if samples.ndim not in (1, 2) or samples.size == 0:
        raise MiketalkError(
            f"audio must be a non-empty (n,) or (n, channels) array, got shape {samples.shape}"
        )
    if samples.ndim == 1 and samples.dtype == np.int16 and rate == ALIGN_RATE:
        return samples
    if samples.dtype.kind in "iu":
        x = samples.astype(np.float64)
    elif samples.dtype.kind == "f":
        x = samples.astype(np.float64) * 32767.0
    else:
        raise MiketalkError(f"audio samples must be integers or floats, got {samples.dtype}")
    if x.ndim == 2:
        x = x.mean(axis=1)
    if not np.all(np.isfinite(x)):
        raise MiketalkError("audio samples must be finite")
    x = _resample(x, rate, ALIGN_RATE)
    return np.clip(np.round(x), -32768, 32767).astype(np.int16)


# ---------------------------------------------------------------------------
# the aligner
# ---------------------------------------------------------------------------


class _Aligner:
    """A pocketsphinx decoder (1 s to load its dictionary) and the words added to it."""

    def __init__(self) -> None:
        import pocketsphinx

        config = pocketsphinx.Config(loglevel="FATAL", **_DECODER_SETTINGS)
        self.decoder = pocketsphinx.Decoder(config)
        self.frate = int(self.decoder.config["frate"])
        self.window = float(self.decoder.config["wlen"])  # seconds
        self.added: dict[str, tuple[str, ...]] = {}

    def in_dictionary(self, word: str) -> bool:
        return word not in self.added and self.decoder.lookup_word(word) is not None

    def add(self, word: str, arpabet: tuple[str, ...]) -> None:
        self.decoder.add_word(word, " ".join(arpabet), True)
        self.added[word] = arpabet

    def _start(self) -> None:
        # a fresh front end: its noise estimate would otherwise carry over from the
        # last utterance, and an alignment would depend on what was aligned before
        self.decoder.reinit_feat()
        self.decoder.start_utt()

    def words_placed(self, pcm: bytes, words: Sequence[str]) -> list[str]:
        """The word pass: the words the aligner placed (all of them, or fewer)."""
        self.decoder.set_align_text(" ".join(words))
        try:
            self._start()
            self.decoder.process_raw(pcm, full_utt=True)
            self.decoder.end_utt()
        except RuntimeError:
            return []
        hyp = self.decoder.hyp()
        return hyp.hypstr.split() if hyp is not None else []

    def phone_pass(self, pcm: bytes) -> list[tuple[str, list[tuple[str, int, int, int]]]]:
        """The phone pass after a complete word pass.

        Returns ``(word, [(phone, start, end, end of its first HMM state)])``, in frames.
        """
        self.decoder.set_alignment()
        self._start()
        self.decoder.process_raw(pcm, full_utt=True)
        self.decoder.end_utt()
        alignment = self.decoder.get_alignment()
        # iterating one phone's states crashes pocketsphinx 5.1.1: walk the flat list
        first_state_end = {}
        for state in alignment.states():
            first_state_end.setdefault(state.start, state.start + state.duration)
        return [
            (
                word.name,
                [
                    (p.name, p.start, p.start + p.duration, first_state_end.get(p.start, p.start))
                    for p in word
                ],
            )
            for word in alignment.words()
        ]


_LOCK = threading.Lock()  # one alignment at a time: the decoder is shared
_SHARED: list[_Aligner] = []  # the shared aligner, once loaded


def _shared_aligner(pronunciations: Mapping[str, tuple[str, ...]] | None = None) -> _Aligner:
    """The shared aligner, with ``pronunciations`` (ARPAbet) in its dictionary.

    A word added earlier with another pronunciation cannot be replaced in
    pocketsphinx's dictionary: the aligner is then loaded afresh.
    """
    pronunciations = pronunciations or {}
    if not _SHARED or any(
        _SHARED[0].added.get(w, arpa) != arpa for w, arpa in pronunciations.items()
    ):
        _SHARED[:] = [_Aligner()]
    aligner = _SHARED[0]
    for word, arpa in pronunciations.items():
        if word not in aligner.added:
            try:
                aligner.add(word, arpa)
            except RuntimeError as err:
                raise MiketalkError(f"cannot add the word {word!r} as {' '.join(arpa)}") from err
    return aligner


def _pronunciations(
    words: Sequence[str], aligner: _Aligner, pronounce: Callable[[str], Sequence[str]] | None
) -> dict[str, tuple[str, ...]]:
    """Festival-phone pronunciations of the words the CMU dictionary lacks."""
    missing = [w for w in dict.fromkeys(words) if not aligner.in_dictionary(w)]
    if not missing:
        return {}
    if pronounce is None:
        exe = os.environ.get("MIKETALK_FESTIVAL") or "festival"
        return _festival_lookup(missing, exe)
    silent = {f for f, arpa in arpabet_table().from_festival.items() if arpa == ("SIL",)}
    result = {}
    for word in missing:
        phones = tuple(str(p) for p in pronounce(word) if str(p) not in silent)
        if not phones:
            raise MiketalkError(f"no pronunciation of the word {word!r}")
        result[word] = phones
    return result


def _festival_lookup(words: list[str], executable: str) -> dict[str, tuple[str, ...]]:
    """Festival's pronunciations, from one run for the words not looked up before.

    Kept for the process: Festival's lexicon does not change while it runs.
    """
    todo = [w for w in words if (w, executable) not in _FESTIVAL_CACHE]
    if todo:
        found = _run_festival_lexicon(todo, executable, 120.0)
        for word in todo:
            _FESTIVAL_CACHE[(word, executable)] = tuple(found[word])
    return {w: _FESTIVAL_CACHE[(w, executable)] for w in words}


def _to_arpabet(word: str, festival: Sequence[str]) -> tuple[str, ...]:
    table = arpabet_table().from_festival
    arpabet: list[str] = []
    for phone in festival:
        if phone not in table:
            raise MiketalkError(
                f"the pronunciation of {word!r} has {phone!r}, not a Festival radio phone"
            )
        if table[phone] == ("SIL",):
            raise MiketalkError(f"the pronunciation of {word!r} has the silence {phone!r}")
        arpabet += table[phone]
    return tuple(arpabet)


def _festival_names(
    word: str, phones: list[tuple[str, float, float]], festival: Sequence[str] | None
) -> list[tuple[str, float, float]]:
    """A word's aligned ARPAbet phones under Festival's names.

    A word pronounced in Festival phones gets them back (two ARPAbet phones
    joined again for ``el``, ``em``, ``en``); others go through the table.
    """
    table = arpabet_table()
    if festival is not None:
        sizes = [len(table.from_festival[f]) for f in festival]
        if sum(sizes) == len(phones):
            named, i = [], 0
            for name, size in zip(festival, sizes, strict=True):
                named.append((name, phones[i][1], phones[i + size - 1][2]))
                i += size
            return named
    out = []
    for name, start, end in phones:
        if name not in table.to_festival:
            raise MiketalkError(f"the aligner gave {word!r} the unknown phone {name!r}")
        out.append((table.to_festival[name], start, end))
    return out


def _first_unplaced(aligner: _Aligner, pcm: bytes, words: Sequence[str], placed: list[str]) -> int:
    """Index of the first word the aligner cannot place (a binary search over prefixes)."""
    if placed and words[: len(placed)] == placed:
        return len(placed)
    good, bad = 0, len(words)  # words[:good] align (trivially for 0); words[:bad] do not
    while bad - good > 1:
        middle = (good + bad) // 2
        if _strip(aligner.words_placed(pcm, words[:middle])) == list(words[:middle]):
            good = middle
        else:
            bad = middle
    return good


def _strip(hyp: Iterable[str]) -> list[str]:
    """Hypothesis words without alternate-pronunciation marks and fillers."""
    return [re.sub(r"\(\d+\)$", "", w) for w in hyp if not w.startswith(("<", "[", "+"))]


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
    """

    words: tuple[WordTiming, ...]
    phones: tuple[Phone, ...]


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
        As :func:`align_phones`.
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
            raise MiketalkError(
                f"cannot align the word {words[index]!r} (word {index + 1} of {len(clean)}) "
                "to the audio: is it said there?"
            )
        try:
            aligned = aligner.phone_pass(data)
        except RuntimeError:
            raise MiketalkError(
                f"the aligner placed the words {' '.join(clean)!r} but not their phones"
            ) from None
    frate = aligner.frate
    spans, phones = _read_alignment(aligned, frate, extra)
    if timings is not None:
        found = [WordTiming(w, g0, g1) for w, (g0, g1) in zip(clean, timings, strict=True)]
        return Alignment(tuple(found), tuple(_contiguous(_stretch(spans, timings), duration)))
    found = [
        WordTiming(w, a0, min(a1, duration)) for w, (a0, a1, _) in zip(clean, spans, strict=True)
    ]
    slack = 1.0 / frate + aligner.window
    return Alignment(tuple(found), tuple(_contiguous(phones, duration, slack=slack)))


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
