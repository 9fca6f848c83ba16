"""Audio alignment: find spoken words in a recording and map predicted times into it.

A corpus recording is a list of words spoken with pauses between them. Each
word is located by its energy (one speech segment per word), then Festival's
synthesis of that word is aligned to the recorded word by dynamic time warping
of log-mel spectra, which maps any predicted time (a phone's middle) to the
recording's time. With the synthetic subject, whose audio is Festival's, the
alignment is the identity; with a person, it is alignment by synthesis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from miketalk.errors import MiketalkError

HOP = 0.010  # seconds between feature frames
WINDOW = 0.025


def _mel_filters(rate: int, n_fft: int, n_mels: int) -> np.ndarray:
    def mel(f: np.ndarray) -> np.ndarray:
        return 2595.0 * np.log10(1.0 + f / 700.0)

    edges = 700.0 * (
        10 ** (np.linspace(mel(np.array(60.0)), mel(np.array(rate / 2)), n_mels + 2) / 2595.0) - 1
    )
    bins = np.fft.rfftfreq(n_fft, 1.0 / rate)
    lo, mid, hi = edges[:-2, None], edges[1:-1, None], edges[2:, None]
    return np.maximum(0.0, np.minimum((bins - lo) / (mid - lo), (hi - bins) / (hi - mid)))


def log_mel(samples: np.ndarray, rate: int, *, n_mels: int = 40) -> np.ndarray:
    """Log-mel spectrum every 10 ms (25 ms Hann windows), shape ``(frames, n_mels)``."""
    x = samples.astype(np.float64) / 32768.0
    win, hop = round(WINDOW * rate), round(HOP * rate)
    n = max(1, 1 + (len(x) - win) // hop) if len(x) >= win else 1
    x = np.pad(x, (0, max(0, (n - 1) * hop + win - len(x))))
    frames = np.lib.stride_tricks.sliding_window_view(x, win)[::hop][:n] * np.hanning(win)
    n_fft = 1 << (win - 1).bit_length()
    power = np.abs(np.fft.rfft(frames, n_fft)) ** 2
    return np.log(power @ _mel_filters(rate, n_fft, n_mels).T + 1e-10)


def energy_db(samples: np.ndarray, rate: int) -> np.ndarray:
    """Frame energy in dB every 10 ms."""
    hop = round(HOP * rate)
    n = len(samples) // hop
    x = samples[: n * hop].astype(np.float64).reshape(n, hop) / 32768.0
    return 10 * np.log10(np.mean(x * x, axis=1) + 1e-12)


@dataclass(frozen=True)
class Segment:
    """A span of speech in seconds."""

    start: float
    end: float


def speech_segments(
    samples: np.ndarray, rate: int, *, min_gap: float = 0.15, min_length: float = 0.05
) -> list[Segment]:
    """Spans of speech: energy within 40 dB of the loudest 10 ms, short gaps bridged.

    Stop closures inside a word are shorter than ``min_gap`` and are bridged; the
    pauses between corpus words are longer.
    """
    db = energy_db(samples, rate)
    if db.size == 0:
        return []
    floor = np.percentile(db, 5)
    threshold = max(floor + 12.0, db.max() - 40.0)
    on = db > threshold
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(np.int8), [0]])))
    spans = [[a * HOP, b * HOP] for a, b in zip(edges[::2], edges[1::2], strict=True)]
    merged: list[list[float]] = []
    for span in spans:
        if merged and span[0] - merged[-1][1] < min_gap:
            merged[-1][1] = span[1]
        else:
            merged.append(span)
    return [Segment(a, b) for a, b in merged if b - a >= min_length]


def _dtw_path(cost: np.ndarray) -> np.ndarray:
    """The classic symmetric DTW path through ``cost`` (n, m), as (i, j) pairs from (0, 0).

    The accumulated cost is filled one anti-diagonal at a time (every cell of
    diagonal ``i + j = k`` depends only on diagonals ``k - 1`` and ``k - 2``), so
    each diagonal is one vectorised step. The path is traced back from the end,
    preferring the diagonal step, then the step in ``i``, then in ``j``.
    """
    n, m = cost.shape
    acc = np.full((n + 1, m + 1), np.inf)
    acc[0, 0] = 0.0
    for k in range(2, n + m + 1):
        i = np.arange(max(1, k - m), min(n, k - 1) + 1)
        j = k - i
        best = np.minimum(np.minimum(acc[i - 1, j - 1], acc[i - 1, j]), acc[i, j - 1])
        acc[i, j] = cost[i - 1, j - 1] + best
    path = []
    i, j = n, m
    while i > 0 and j > 0:
        path.append((i - 1, j - 1))
        diag, up, left = acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1]
        if diag <= up and diag <= left:
            i, j = i - 1, j - 1
        elif up <= left:
            i -= 1
        else:
            j -= 1
    return np.array(path[::-1], dtype=np.int64).reshape(-1, 2)


def dtw_map(reference: np.ndarray, query: np.ndarray) -> np.ndarray:
    """For each frame of ``reference``, the matching (mean) frame index of ``query``.

    Features are mean- and variance-normalized per utterance; the local cost is
    the Euclidean distance; the path is the classic symmetric DTW.
    """

    def norm(f: np.ndarray) -> np.ndarray:
        return (f - f.mean(axis=0)) / (f.std(axis=0) + 1e-6)

    a, b = norm(reference), norm(query)
    cost = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2))
    path = _dtw_path(cost)
    out = np.zeros(len(reference))
    counts = np.zeros(len(reference))
    np.add.at(out, path[:, 0], path[:, 1])
    np.add.at(counts, path[:, 0], 1)
    return out / np.maximum(counts, 1)


def map_times(
    predicted: np.ndarray, predicted_rate: int, recorded: np.ndarray, recorded_rate: int
) -> callable:
    """A function taking times in ``predicted`` audio to times in ``recorded`` audio."""
    mapping = dtw_map(log_mel(predicted, predicted_rate), log_mel(recorded, recorded_rate))
    grid = np.arange(len(mapping)) * HOP

    def to_recorded(t: float | np.ndarray) -> np.ndarray:
        return np.interp(t, grid, mapping * HOP)

    return to_recorded


def locate_words(samples: np.ndarray, rate: int, n_words: int) -> list[Segment]:
    """One speech segment per word, or a clear error when the count is off."""
    segments = speech_segments(samples, rate)
    if len(segments) != n_words:
        raise MiketalkError(
            f"found {len(segments)} spoken words in the recording's audio, expected {n_words}: "
            "leave a clear pause between corpus words, or give the viseme frames by hand "
            "(visemes.frames_table in config.yaml)"
        )
    return segments
