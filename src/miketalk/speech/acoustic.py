"""What a recording says of the mouth: its log-mel energies around given times.

The phones say which sounds are made, not how loud or how open: a stressed
vowel and an unstressed one are the same phone. When a recording drives the
face (``say --audio``, ``dub``, the held-out evaluation), its spectrum carries
that too. :func:`heard_features` gives, for each time ``t``, the log energies
of :data:`BANDS` mel bands in a :data:`WINDOW` window centred at
``t + k * step`` for ``k = -half .. half``, each band standardized over the
whole recording (its mean and spread on a 10 ms grid), so that a louder
microphone or another voice's timbre shifts nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from miketalk.errors import MiketalkError

#: The rate the features are computed at (other rates are resampled to it).
RATE = 16000
#: Analysis window (s), mel bands and their edges (Hz).
WINDOW = 0.025
BANDS = 24
FMIN, FMAX = 60.0, 7600.0
#: The grid (s) the standardization is measured on.
GRID = 0.01
#: Windows whose spectra are computed at a time (:func:`mel_energies`): a 12-minute
#: recording's grid of 71,000 windows at once held 1.5 GB of segments and spectra.
BLOCK = 4096


@dataclass(frozen=True)
class Recording:
    """Mono samples and their rate: the sound that drives an utterance."""

    samples: np.ndarray
    rate: int

    def at_rate(self) -> np.ndarray:
        """The samples as float32 at :data:`RATE`."""
        x = np.asarray(self.samples, np.float32).reshape(-1)
        if self.rate == RATE:
            return x
        if self.rate <= 0:
            raise MiketalkError(f"a recording's sample rate must be positive, not {self.rate}")
        from math import gcd

        from scipy.signal import resample_poly

        g = gcd(RATE, int(self.rate))
        return resample_poly(x, RATE // g, int(self.rate) // g).astype(np.float32)


@lru_cache(maxsize=1)
def mel_bank() -> np.ndarray:
    """``(BANDS, n_fft // 2 + 1)`` triangular mel filters at :data:`RATE`."""
    n_fft = _n_fft()

    def mel(f):
        return 2595.0 * np.log10(1.0 + np.asarray(f) / 700.0)

    edges = 700.0 * (10 ** (np.linspace(mel(FMIN), mel(FMAX), BANDS + 2) / 2595.0) - 1.0)
    bins = np.fft.rfftfreq(n_fft, 1.0 / RATE)
    lo, mid, hi = edges[:-2, None], edges[1:-1, None], edges[2:, None]
    rising, falling = (bins - lo) / (mid - lo), (hi - bins) / (hi - mid)
    return np.clip(np.minimum(rising, falling), 0.0, None)


def _n_fft() -> int:
    return 1 << (round(WINDOW * RATE) - 1).bit_length()


def mel_energies(samples: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``(len(times), BANDS)`` mel band energies of ``samples`` (at :data:`RATE`) in a Hann
    window centred at each time (zeros outside the recording).

    The power spectra are computed :data:`BLOCK` windows at a time (each window's the same
    bytes in any block) into one array, 2 KB a window (12 MB a minute on the 10-ms grid),
    and projected on the mel bank at once: BLAS rounds a row of a product differently in
    another block, and the bytes stay those of the whole."""
    width = round(WINDOW * RATE)
    times = np.asarray(times, float)
    window = np.hanning(width)
    spectrum = np.empty((len(times), _n_fft() // 2 + 1))
    for start in range(0, len(times), BLOCK):
        centres = np.round(times[start : start + BLOCK] * RATE).astype(np.int64)
        index = centres[:, None] + (np.arange(width) - width // 2)[None, :]
        inside = (index >= 0) & (index < len(samples))
        if len(samples):
            segments = np.where(inside, samples[np.clip(index, 0, len(samples) - 1)], 0.0)
        else:
            segments = np.zeros(index.shape)
        block = np.abs(np.fft.rfft(segments * window, _n_fft(), axis=1)) ** 2
        spectrum[start : start + len(block)] = block
    return spectrum @ mel_bank().T


def heard_features(
    recording: Recording, times: np.ndarray, *, half: int, step: float
) -> np.ndarray:
    """``(len(times), (2 half + 1) BANDS)``: the standardized log-mel window at each time."""
    samples = recording.at_rate()
    grid = mel_energies(samples, np.arange(0.0, max(len(samples) / RATE, GRID), GRID))
    # silence (and outside the recording) is a floor 50 dB under the recording's mean
    # energy, not log(0): a floor that scales with the recording keeps loudness out
    floor = 1e-5 * float(grid.mean()) + 1e-12
    grid = np.log(grid + floor)
    mean, spread = grid.mean(axis=0), grid.std(axis=0)
    spread = np.where(spread > 1e-6, spread, 1.0)
    times = np.asarray(times, float)
    return np.concatenate(
        [
            (np.log(mel_energies(samples, times + k * step) + floor) - mean) / spread
            for k in range(-half, half + 1)
        ],
        axis=1,
    )


__all__ = ["BANDS", "RATE", "Recording", "heard_features", "mel_bank", "mel_energies"]
