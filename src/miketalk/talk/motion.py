"""Measures of an utterance's motion: its speed against the speech's own, its steps, its
smoothness.

Three questions about a rendered utterance (``say`` records the answers in its
JSON, under ``motion``):

* **duration ratio**: how much longer the speech became than the engine's
  own timing (1.0 at natural speed; the paper's oversampling makes it 2-5);
* **largest step**: the largest distance, along the flows, between two
  consecutive rendered morphs (:func:`miketalk.talk.lipsync.largest_step`),
  what the paper keeps under ``max_px_per_frame``; and the largest motion from
  one frame to the next (:func:`miketalk.talk.lipsync.largest_frame_motion`),
  how fast the mouth moves per frame, which blur leaves as the speech has it;
* **smoothness**, measured on the frames as written: the *jerk*, the mean
  absolute second difference in time of the grey frames
  ``|f[k+1] - 2 f[k] + f[k-1]|`` (grey levels, 0-255), i.e. how much a frame
  differs from the average of its two neighbours. Motion that proceeds evenly
  gives a small jerk; a jump between two frames that stand still gives a
  large one. Both the largest and the mean over frames are kept.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass

import cv2
import numpy as np

from miketalk.talk.lipsync import Displacement, Timeline, largest_frame_motion, largest_step


class JerkMeter:
    """Measures the jerk of frames as they stream past (see the module docstring)."""

    def __init__(self) -> None:
        self._before: np.ndarray | None = None  # frame k - 1
        self._last: np.ndarray | None = None  # frame k
        self.count = 0
        self.largest = 0.0
        self.total = 0.0

    def add(self, frame: np.ndarray) -> None:
        """Take the next frame ((H, W, 3) RGB or (H, W) grey, uint8)."""
        grey = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY) if frame.ndim == 3 else frame
        grey = grey.astype(np.int16)
        if self._last is not None and self._before is not None:
            jerk = float(np.abs(grey - 2 * self._last + self._before).mean())
            self.largest = max(self.largest, jerk)
            self.total += jerk
            self.count += 1
        self._before, self._last = self._last, grey

    def watch(self, frames: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
        """Yield ``frames`` unchanged, measuring each."""
        for frame in frames:
            self.add(frame)
            yield frame

    @property
    def mean(self) -> float:
        """The mean jerk over the frames that have two neighbours (0 for fewer than 3)."""
        return self.total / self.count if self.count else 0.0


@dataclass(frozen=True)
class Motion:
    """The measures of one utterance (see the module docstring).

    Attributes
    ----------
    natural_duration, duration : float
        Seconds of speech at the engine's own timing, and as spoken.
    duration_ratio : float
        ``duration / natural_duration``.
    frames, morphs : int
        Frames written, and morphs rendered into them.
    largest_step_px : float
        Largest distance between consecutive morphs, pixels.
    largest_frame_motion_px : float
        Largest motion from one frame's middle to the next's, pixels.
    largest_jerk, mean_jerk : float or None
        Jerk of the frames written, grey levels (None when not measured).
    """

    natural_duration: float
    duration: float
    duration_ratio: float
    frames: int
    morphs: int
    largest_step_px: float
    largest_frame_motion_px: float
    largest_jerk: float | None = None
    mean_jerk: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return asdict(self)


def measure(
    timeline: Timeline,
    displacement: Displacement,
    *,
    natural_duration: float,
    jerk: JerkMeter | None = None,
) -> Motion:
    """The :class:`Motion` of ``timeline`` (and of its frames, measured by ``jerk``)."""
    return Motion(
        natural_duration=natural_duration,
        duration=timeline.duration,
        duration_ratio=timeline.duration / natural_duration,
        frames=len(timeline.frames),
        morphs=timeline.morph_count,
        largest_step_px=largest_step(timeline, displacement),
        largest_frame_motion_px=largest_frame_motion(timeline, displacement),
        largest_jerk=None if jerk is None else jerk.largest,
        mean_jerk=None if jerk is None else jerk.mean,
    )
