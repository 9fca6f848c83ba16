"""pocketsphinx's aligner, shared by the process: audio in its rate and format, words placed."""

from __future__ import annotations

import math
import re
import threading
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from miketalk.errors import MiketalkError

#: The aligner's sample rate (its acoustic model's).
ALIGN_RATE = 16000


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


#: Pronunciations the CMU dictionary (American English) lacks for words it has, added as
#: alternates (``word(n)``): the aligner, and the long aligner's recogniser, take whichever
#: fits the sound. The letter z said "zed" (British and Commonwealth English, as GRID
#: talker 1 says it): with "zee" alone, the aligner squeezed the z into the closure of its
#: "d" and gave "with" the sound of "with z" in "lay red with z five again". On the 8 of the 200
#: benchmark clips of GRID talker 1 that say z, each clip's score per frame rose by 3.7 to
#: 9.8 (mean -23.7 to -17.7; the worst right transcript of the 200, "place green with z zero
#: please", from -34.6 to -26.3) and the word boundaries within 50 ms of GRID's from 74 to
#: 82 %; the long aligner leaves out no word said "zed" that clip-by-clip alignment places
#: (``python -m miketalk_lab.bench.script_fit``, docs/build.md).
ALTERNATES: dict[str, tuple[str, ...]] = {"z(2)": ("Z", "EH", "D")}


class _Aligner:
    """A pocketsphinx decoder (1 s to load its dictionary, :data:`ALTERNATES` added) and the
    words added to it."""

    def __init__(self, settings: Mapping[str, object] | None = None) -> None:
        import pocketsphinx

        config = pocketsphinx.Config(loglevel="FATAL", **(settings or _DECODER_SETTINGS))
        self.decoder = pocketsphinx.Decoder(config)
        self.frate = int(self.decoder.config["frate"])
        self.window = float(self.decoder.config["wlen"])  # seconds
        self.added: dict[str, tuple[str, ...]] = {}
        self.score_per_frame: float | None = None
        for name, arpabet in ALTERNATES.items():
            if self.decoder.lookup_word(name) is None:
                self.decoder.add_word(name, " ".join(arpabet), True)

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
        spoken = [
            w
            for w in alignment.words()
            if not w.name.startswith(("<", "[", "+")) and w.name != "sil"
        ]
        frames = sum(w.duration for w in spoken)
        #: the acoustic score per frame of the words (not the silences) of the last pass
        self.score_per_frame = sum(w.score for w in spoken) / frames if frames else None
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


_SHARED: dict[str, _Aligner] = {}  # the shared aligners, once loaded: "fine" and "coarse"


#: The coarse aligner's settings: pocketsphinx's default beams and no best-path pass.
#: It finds where the words of minutes of speech are (10 minutes and 1200 words: 18 s,
#: 190 MB; the wide beams above take 6 GB), for a finer alignment of each piece.
COARSE_SETTINGS: dict[str, object] = {"bestpath": False}


def coarse_word_spans(pcm: bytes, words: Sequence[str], extra: Mapping[str, tuple[str, ...]]):
    """Each word's first and last frame (inclusive) in ``pcm``, by the coarse aligner; the
    aligner's frame rate. ``extra`` are ARPAbet pronunciations of words the dictionary lacks.

    Raises
    ------
    MiketalkError
        When it cannot place all the words.
    """
    with _LOCK:
        aligner = _shared_aligner(extra, coarse=True)
        if _strip(aligner.words_placed(pcm, words)) != list(words):
            raise MiketalkError("the coarse pass could not place every word")
        spans = [
            (s.start_frame, s.end_frame)
            for s in aligner.decoder.seg()
            if not s.word.startswith(("<", "[", "+"))
        ]
    return spans, aligner.frate


def _shared_aligner(
    pronunciations: Mapping[str, tuple[str, ...]] | None = None, *, coarse: bool = False
) -> _Aligner:
    """The shared aligner (the coarse one: :data:`COARSE_SETTINGS`), with ``pronunciations``
    (ARPAbet) in its dictionary.

    A word added earlier with another pronunciation cannot be replaced in
    pocketsphinx's dictionary: the aligner is then loaded afresh.
    """
    pronunciations = pronunciations or {}
    kind = "coarse" if coarse else "fine"
    aligner = _SHARED.get(kind)
    if aligner is None or any(
        aligner.added.get(w, arpa) != arpa for w, arpa in pronunciations.items()
    ):
        aligner = _SHARED[kind] = _Aligner(COARSE_SETTINGS if coarse else None)
    for word, arpa in pronunciations.items():
        if word not in aligner.added:
            try:
                aligner.add(word, arpa)
            except RuntimeError as err:
                raise MiketalkError(f"cannot add the word {word!r} as {' '.join(arpa)}") from err
    return aligner


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
