"""How much of a recording's speech its aligned words explain.

A forced aligner places the words it is given; it cannot say that the recording
holds more. Given one word of a six-word sentence it places that word
somewhere and calls the rest silence (``pau``), and a face made from that
timeline stays shut through most of the speech. :func:`speech_coverage`
measures the mismatch: the *voiced* audio is every run of 40 ms frames, at
least 0.12 s long, whose level is well above the recording's noise floor (an
energy detector: it cannot tell speech from a cough or music, which is why
:mod:`miketalk.talk.recorded` warns rather than refuses), and the share of it
outside every aligned non-silent phone is what the words leave unexplained.

On the 48 GRID clips of ``data/grid_s1`` aligned with their own transcripts
(text only, no word timings) none is unexplained; aligned with their first
word only, 43 to 86 per cent is (a tenth of the clips under 56 per cent). A
transcript that names fewer words but lets the aligner stretch them over the
whole speech (three of the six: 16 of the 48 clips leave under 5 per cent
unexplained) is not caught by this measure.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from miketalk.speech.types import Phone

#: Analysis frame and hop, seconds.
FRAME_SECONDS = 0.04
HOP_SECONDS = 0.01

#: A frame is loud when its level is this many dB above the noise floor (the
#: quietest tenth of the frames) and no more than :data:`BELOW_PEAK_DB` below the loudest.
ABOVE_FLOOR_DB = 15.0
BELOW_PEAK_DB = 35.0

#: Loud frames count as voiced in runs at least this long (seconds).
MIN_RUN_SECONDS = 0.12

#: Voiced audio this close to an aligned phone (seconds) counts as explained:
#: aligners place boundaries to about a frame, and breath runs into speech.
MARGIN_SECONDS = 0.06

#: The share of the voiced audio left unexplained above which a recording and
#: its words are reported as a mismatch.
UNEXPLAINED_LIMIT = 0.25


@dataclass(frozen=True)
class SpeechCoverage:
    """The voiced audio of a recording and how much of it lies outside the aligned phones.

    Attributes
    ----------
    voiced_seconds : float
        Seconds of voiced audio (see the module docstring).
    unexplained_seconds : float
        Of those, the seconds outside every aligned non-silent phone (with
        :data:`MARGIN_SECONDS` around each).
    longest_unexplained : float
        The longest run of them (seconds).
    """

    voiced_seconds: float
    unexplained_seconds: float
    longest_unexplained: float = 0.0

    @property
    def unexplained_share(self) -> float:
        """``unexplained_seconds / voiced_seconds`` (0 for a recording with no voiced audio)."""
        return self.unexplained_seconds / self.voiced_seconds if self.voiced_seconds else 0.0

    @property
    def mismatch(self) -> bool:
        """Whether more than :data:`UNEXPLAINED_LIMIT` of the voiced audio is unexplained."""
        return self.unexplained_share > UNEXPLAINED_LIMIT


def voiced_frames(samples: np.ndarray, rate: int) -> np.ndarray:
    """Which analysis frames are voiced: a bool array, frame ``k`` starting at ``k * hop``.

    A frame is voiced when it is loud (:data:`ABOVE_FLOOR_DB` above the noise
    floor, the quietest tenth of the frames, and within :data:`BELOW_PEAK_DB`
    of the loudest frame) in a run of loud frames at least
    :data:`MIN_RUN_SECONDS` long: a click, a breath or the rustle before and
    after a sentence is loud for a moment, speech for a syllable or more.

    Parameters
    ----------
    samples : numpy.ndarray
        Mono audio, shape ``(n,)``, any scale (int16 or float).
    rate : int
        Sample rate in Hz.
    """
    x = np.asarray(samples).reshape(-1)
    frame, hop = round(FRAME_SECONDS * rate), round(HOP_SECONDS * rate)
    if len(x) < frame:
        return np.zeros(0, bool)
    level = frame_levels(x, frame, hop)
    floor, peak = np.percentile(level, 10), level.max()
    loud = (level > floor + ABOVE_FLOOR_DB) & (level > peak - BELOW_PEAK_DB)
    # keep the runs of loud frames that last long enough
    edges = np.flatnonzero(np.diff(np.r_[0, loud.astype(np.int8), 0]))
    voiced = np.zeros_like(loud)
    for start, end in zip(edges[::2], edges[1::2], strict=True):
        if (end - start) * HOP_SECONDS >= MIN_RUN_SECONDS - 1e-9:
            voiced[start:end] = True
    return voiced


def frame_levels(x: np.ndarray, frame: int, hop: int, *, block: int = 2048) -> np.ndarray:
    """Level (dB) of each ``frame``-sample window of ``x`` every ``hop`` samples, its mean removed.

    ``block`` windows at a time, in float64: the windows overlap (``frame / hop``
    times), so all of them at once would hold that many copies of a long recording
    (4 at 40 ms every 10 ms: 300 MB for 10 minutes at 16 kHz, twice over).
    """
    windows = np.lib.stride_tricks.sliding_window_view(x, frame)[::hop]
    level = np.empty(len(windows))
    for lo in range(0, len(windows), block):
        part = windows[lo : lo + block].astype(np.float64)
        part -= part.mean(axis=1, keepdims=True)  # no DC offset
        np.square(part, out=part)
        level[lo : lo + block] = 10 * np.log10(part.mean(axis=1) + 1e-12)
    return level


def speech_coverage(samples: np.ndarray, rate: int, phones: Sequence[Phone]) -> SpeechCoverage:
    """How much of the voiced audio of ``samples`` the non-silent ``phones`` cover.

    Parameters
    ----------
    samples : numpy.ndarray
        Mono audio, shape ``(n,)``.
    rate : int
        Sample rate in Hz.
    phones : sequence of Phone
        The aligned phones (``pau`` is silence), seconds from the start.
    """
    voiced = voiced_frames(samples, rate)
    centres = (np.arange(len(voiced)) * HOP_SECONDS) + FRAME_SECONDS / 2
    explained = np.zeros(len(voiced), bool)
    for p in phones:
        if p.name != "pau":
            explained |= (centres >= p.start - MARGIN_SECONDS) & (centres < p.end + MARGIN_SECONDS)
    outside = voiced & ~explained
    edges = np.flatnonzero(np.diff(np.r_[0, outside.astype(np.int8), 0]))
    longest = int((edges[1::2] - edges[::2]).max()) if len(edges) else 0
    return SpeechCoverage(
        voiced_seconds=float(voiced.sum() * HOP_SECONDS),
        unexplained_seconds=float(outside.sum() * HOP_SECONDS),
        longest_unexplained=longest * HOP_SECONDS,
    )
