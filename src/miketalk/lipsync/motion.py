"""Measures of an utterance's motion: its speed against the speech's own, its steps, its
smoothness.

Three questions about a rendered utterance (``say`` records the answers in its
JSON, under ``motion``):

* **duration ratio**: how much longer the speech became than the engine's
  own timing (1.0 at natural speed; the paper's oversampling makes it 2-5);
* **largest step**: the largest distance, along the flows, between two
  consecutive rendered morphs (:func:`miketalk.lipsync.sampling.largest_step`),
  what the paper keeps under ``max_px_per_frame``; and the largest motion from
  one frame to the next (:func:`miketalk.lipsync.sampling.largest_frame_motion`),
  how fast the mouth moves per frame, which blur leaves as the speech has it;
* **smoothness**, measured on the frames as written: the *jerk*, the mean
  absolute second difference in time of the grey frames
  ``|f[k+1] - 2 f[k] + f[k-1]|`` (grey levels, 0-255), i.e. how much a frame
  differs from the average of its two neighbours. Motion that proceeds evenly
  gives a small jerk; a jump between two frames that stand still gives a
  large one. Both the largest and the mean over frames are kept.

With the learned lip-sync model a frame is not a point on one transition but
weights over several visemes (:func:`miketalk.draw.coarticulation.frame_weights`).
The step between two frames is then the least displacement that moves the
first frame's weights into the second's (:func:`weights_step`, the earth
mover's distance with the flows' displacement between two visemes as the cost):
for two frames on one transition ``A -> B`` it is the paper's
``D(A, B) * |alpha_2 - alpha_1|``.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass
from itertools import pairwise

import cv2
import numpy as np

from miketalk.lipsync.sampling import Displacement, largest_frame_motion, largest_step
from miketalk.lipsync.timeline import Timeline


class JerkMeter:
    """Measures the jerk of frames as they stream past (see the module docstring); with
    ``region`` ``(x0, y0, x1, y1)``, of those pixels only (a frame composited into video:
    the mouth's region, the only one drawn)."""

    def __init__(self, region: tuple[int, int, int, int] | None = None) -> None:
        self.region = region  # (x0, y0, x1, y1): the frames' pixels measured (None: all)
        self._before: np.ndarray | None = None  # frame k - 1
        self._last: np.ndarray | None = None  # frame k
        self.count = 0
        self.largest = 0.0
        self.total = 0.0

    def add(self, frame: np.ndarray) -> None:
        """Take the next frame ((H, W, 3) RGB or (H, W) grey, uint8)."""
        if self.region is not None:
            x0, y0, x1, y1 = self.region
            frame = frame[y0:y1, x0:x1]
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
        Frames written, and morphs rendered into them (one a frame when each frame is one of
        the person's own images, as the trained face draws them).
    largest_step_px : float or None
        Largest distance between consecutive morphs, pixels (None: the frames are the
        person's own images, no morphs between visemes whose flows would measure it).
    largest_frame_motion_px : float or None
        Largest motion from one frame's middle to the next's, pixels (None as above).
    largest_jerk, mean_jerk : float or None
        Jerk of the frames written, grey levels (None when not measured).
    """

    natural_duration: float
    duration: float
    duration_ratio: float
    frames: int
    morphs: int
    largest_step_px: float | None
    largest_frame_motion_px: float | None
    largest_jerk: float | None = None
    mean_jerk: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return asdict(self)


#: A frame's visemes and their weights (summing to 1).
Weights = Sequence[tuple[str, float]]


def weights_step(a: Weights, b: Weights, displacement: Displacement) -> float:
    """The displacement in pixels from a frame of weights ``a`` to one of weights ``b``.

    The least cost of moving ``a``'s weight onto ``b``'s, moving weight ``m``
    from viseme ``U`` to ``V`` costing ``m * displacement(U, V)``: a
    transportation problem, solved exactly. Weight a viseme keeps costs
    nothing; what is left usually leaves one or two visemes (solved in closed
    form), rarely more (a linear program).
    """
    wa, wb = dict(a), dict(b)
    for v in set(wa) & set(wb):
        kept = min(wa[v], wb[v])
        wa[v] -= kept
        wb[v] -= kept
    sources = [v for v, w in wa.items() if w > 1e-12]
    targets = [v for v, w in wb.items() if w > 1e-12]
    if not sources or not targets:
        return 0.0
    cost = np.array([[displacement(u, v) for v in targets] for u in sources], np.float64)
    return _transport(cost, np.array([wa[u] for u in sources]), np.array([wb[v] for v in targets]))


def _transport(cost: np.ndarray, supply: np.ndarray, demand: np.ndarray) -> float:
    """The least cost of moving ``supply`` (n,) onto ``demand`` (m,) at ``cost`` (n, m) per unit."""
    if len(supply) > len(demand):
        cost, supply, demand = cost.T, demand, supply
    if len(supply) == 1:
        return float(cost[0] @ demand)
    if len(supply) == 2:
        # what the first source sends to target j is x_j, the second sends the rest:
        # the cost is linear in x, sum x = supply[0], 0 <= x <= demand (a fractional knapsack)
        sent, left = np.zeros_like(demand), supply[0]
        for j in np.argsort(cost[0] - cost[1], kind="stable"):
            sent[j] = min(demand[j], left)
            left -= sent[j]
        return float(cost[0] @ sent + cost[1] @ (demand - sent))
    from scipy.optimize import linprog  # three visemes on each side: rare

    n, m = cost.shape
    rows = np.zeros((n + m, n * m))
    for i in range(n):
        rows[i, i * m : (i + 1) * m] = 1.0
    for j in range(m):
        rows[n + j, j::m] = 1.0
    sums = np.concatenate([supply, demand])
    # both sides move the same mass: one equation follows from the others
    result = linprog(cost.ravel(), A_eq=rows[:-1], b_eq=sums[:-1], bounds=(0, None), method="highs")
    return float(result.fun)


class StepMeter:
    """The steps of the learned lip-sync's frames measured as they are drawn, sentence by
    sentence (:meth:`add`), for :func:`measure`: how many states were drawn and the largest
    step between consecutive frames' weights and between consecutive states, the last of
    each kept to meet the next. Holding every frame's weights for the end instead held
    some 2 KB a frame (an hour's text: 108,000 frames, 200 MB).

    Parameters
    ----------
    displacement : callable
        ``displacement(a, b)``: pixels the flow from viseme ``a`` to ``b`` moves.
    """

    def __init__(self, displacement: Displacement) -> None:
        self.displacement = displacement
        self.frames = 0  # weights given (one a frame)
        self.morphs = 0  # states drawn
        self.frame_motion = 0.0  # the largest step between consecutive frames' weights
        self.step: float | None = None  # between consecutive states (None: no states given)
        self._weights: Weights | None = None
        self._state: Weights | None = None

    def add(self, weights: Sequence[Weights], states: Sequence[Weights] | None = None) -> None:
        """Take the next frames' weights and, with them, the states drawn for them (None:
        the weights are the states drawn)."""
        before = [] if self._weights is None else [self._weights]
        for a, b in pairwise([*before, *weights]):
            self.frame_motion = max(self.frame_motion, weights_step(a, b, self.displacement))
        self._weights = weights[-1] if weights else self._weights
        self.frames += len(weights)
        self.morphs += len(weights if states is None else states)
        if states is not None:
            before = [] if self._state is None else [self._state]
            for a, b in pairwise([*before, *states]):
                self.step = max(self.step or 0.0, weights_step(a, b, self.displacement))
            self.step = self.step or 0.0
            self._state = states[-1] if states else self._state


def measure(
    timeline: Timeline,
    displacement: Displacement,
    *,
    natural_duration: float,
    jerk: JerkMeter | None = None,
    weights: Sequence[Weights] | None = None,
    own_frames: bool = False,
    states: Sequence[Weights] | None = None,
    steps: StepMeter | None = None,
) -> Motion:
    """The :class:`Motion` of ``timeline`` (and of its frames, measured by ``jerk``).

    Parameters
    ----------
    timeline : Timeline
    displacement : callable
        ``displacement(a, b)``: pixels the flow from viseme ``a`` to ``b`` moves.
    natural_duration : float
        Seconds of the speech at the engine's own timing.
    jerk : JerkMeter, optional
        The meter that watched the frames as written.
    weights : sequence of Weights, optional
        The frames' viseme weights when the learned model drew them: the steps
        are then :func:`weights_step` between consecutive frames (one morph a
        frame), not along the timeline's transitions.
    own_frames : bool
        Each frame was one of the person's own images (the trained face,
        :mod:`miketalk.draw.trained`), not a morph along the timeline: one a frame, and the
        step measures, which the visemes' flows give, are None.
    states : sequence of Weights, optional
        With ``weights``: the states drawn, in order, several for a frame averaged from
        several (:func:`miketalk.draw.learned.learned_exposures`); the morphs and the
        largest step are counted on them, the largest frame motion on ``weights`` (one
        a frame). None: ``weights`` are the states drawn.
    steps : StepMeter, optional
        Instead of ``weights`` and ``states``: what was measured of them as they were
        drawn (a text spoken sentence by sentence).
    """
    if steps is None and weights is not None:
        steps = StepMeter(displacement)
        steps.add(weights, states)
    if own_frames:
        morphs, step, frame_motion = len(timeline.frames), None, None
    elif steps is None:
        morphs = timeline.morph_count
        step = largest_step(timeline, displacement)
        frame_motion = largest_frame_motion(timeline, displacement)
    else:
        morphs, frame_motion = steps.morphs, steps.frame_motion
        step = frame_motion if steps.step is None else steps.step
    return Motion(
        natural_duration=natural_duration,
        duration=timeline.duration,
        duration_ratio=timeline.duration / natural_duration,
        frames=len(timeline.frames),
        morphs=morphs,
        largest_step_px=step,
        largest_frame_motion_px=frame_motion,
        largest_jerk=None if jerk is None else jerk.largest,
        mean_jerk=None if jerk is None else jerk.mean,
    )
