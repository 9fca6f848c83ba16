"""Frames drawn with a model's learned coarticulation (:mod:`miketalk.draw.coarticulation`).

Each frame's viseme weights come from the fitted dominance functions at the
frame's middle; the N-way morph (:class:`miketalk.render.multimorph.MultiMorpher`)
draws them.

The step limit (``max_px_per_frame``) holds for the learned path too
(:func:`learned_exposures`), as motion blur keeps it on the paper's path
(:func:`miketalk.lipsync.sampling.motion_blur`): a frame whose drawn state is further
than the limit from its neighbour's, along the flows (the earth mover's distance of
:func:`miketalk.lipsync.motion.weights_step`), is drawn as the average of the states
at ``n`` equal slices of its exposure, ``n`` grown until every two consecutive drawn
states, within a frame and across frames, are at most the limit apart; where the
weights jump (a viseme leaving a frame's few largest), blends of the two states bridge
the jump. A frame averages at most ``MAX_SAMPLES // 2`` slices and ``MAX_SAMPLES``
blends; past that the bound does not hold, and the motion JSON reports the true
largest step.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np

from miketalk.draw.coarticulation import CoarticulationParams, frame_weights
from miketalk.draw.coarticulation.weights import weights_at
from miketalk.lipsync.motion import weights_step
from miketalk.lipsync.sampling import Displacement
from miketalk.lipsync.timeline import Timeline
from miketalk.render.multimorph import Box, MultiMorpher, Weights
from miketalk.workers import RENDER_WORKERS

__all__ = ["MAX_SAMPLES", "Exposure", "learned_exposures", "render_learned", "render_model_learned"]

#: The most drawn states averaged into one frame of the learned lip-sync: half of them
#: slices of its exposure, and as many blends across jumps of the weights.
MAX_SAMPLES = 16

#: A frame's drawn states: each state's weights and its share of the frame (summing to 1).
Exposure = tuple[tuple[Weights, float], ...]


def learned_exposures(
    timeline: Timeline,
    params: CoarticulationParams,
    *,
    displacement: Displacement,
    max_px_per_frame: float | None,
    max_samples: int = MAX_SAMPLES,
    middles: Sequence[Weights] | None = None,
) -> list[Exposure]:
    """Each frame's drawn states, so that consecutive states move at most ``max_px_per_frame``
    (the module docstring); one state (the frame's middle, :func:`frame_weights`) for a frame
    that moves slowly enough, and for every frame when ``max_px_per_frame`` is None.
    ``middles``: ``frame_weights(timeline, params)`` when the caller has them already.
    """
    middles = frame_weights(timeline, params) if middles is None else middles
    if max_px_per_frame is None or not middles:
        return [((row, 1.0),) for row in middles]
    fps, duration = timeline.fps, timeline.duration
    times = [f.time for f in timeline.frames]
    count = [1] * len(times)
    states: list[list[Weights]] = [[row] for row in middles]

    def slices(k: int, n: int) -> list[float]:
        lo, hi = max(0.0, times[k] - 0.5 / fps), min(duration, times[k] + 0.5 / fps)
        width = (hi - lo) / n
        return [lo + (j + 0.5) * width for j in range(n)] if hi > lo else [times[k]]

    limit = max_px_per_frame + 1e-9
    dirty = set(range(len(times)))
    before: dict[int, float] = {}  # each grown frame's largest step before it grew
    for _ in range(2 * max_samples):
        worst: dict[int, float] = {}
        pairs = sorted({j for k in dirty for j in (k, k + 1) if 0 < j < len(times)} | dirty)
        for k in pairs:  # the steps into frame k and within it
            run = ([states[k - 1][-1]] if k > 0 else []) + states[k]
            for i in range(1, len(run)):
                step = weights_step(run[i - 1], run[i], displacement)
                if step > limit:
                    for j in (k,) if i > 1 or k == 0 else (k - 1, k):
                        worst[j] = max(worst.get(j, 0.0), step)
        # a step that slicing did not shorten is a jump of the weights: bridged below
        grow = {
            k: step
            for k, step in worst.items()
            if count[k] < max_samples // 2 and step < 0.9 * before.get(k, math.inf)
        }
        if not grow:
            break
        for k, step in grow.items():
            before[k] = step
            count[k] = min(max_samples // 2, max(count[k] + 1, math.ceil(count[k] * step / limit)))
        ordered = sorted(grow)
        at = [t for k in ordered for t in slices(k, count[k])]
        rows = weights_at(timeline, params, at)
        start = 0
        for k in ordered:
            n = len(slices(k, count[k]))
            states[k], start = rows[start : start + n], start + n
        dirty = set(ordered)
    _bridge(states, displacement, limit, max_samples)
    return [tuple((row, 1.0 / len(rows)) for row in rows) for rows in states]


def _bridge(
    states: list[list[Weights]], displacement: Displacement, limit: float, max_samples: int
) -> None:
    """Put blends between the consecutive states still too far apart (in place; at most
    ``max_samples`` blends a frame).

    Slicing time cannot shorten a step where a viseme leaves the frame's few largest
    (``max_visemes``, ``min_weight``): the weights jump there. The states ``(1 - s) a + s b``
    between the two states ``a`` and ``b`` of such a step are at most ``s`` times its
    length from ``a`` (the earth mover's distance is convex), so ``ceil(step / limit) - 1``
    blends, added to the later state's frame, leave no step over the limit.
    """
    previous: Weights | None = None
    for k, rows in enumerate(states):
        out: list[Weights] = []
        for i, row in enumerate(rows):
            if previous is not None:
                step = weights_step(previous, row, displacement)
                room = max_samples - (len(out) - i)  # blends in this frame so far
                n = min(max(0, math.ceil(step / limit) - 1), room)
                out += [_blend(previous, row, (j + 1) / (n + 1)) for j in range(n)]
            out.append(row)
            previous = row
        states[k] = out


def _blend(a: Weights, b: Weights, s: float) -> Weights:
    """``(1 - s) a + s b``, visemes in the order they first appear in ``a`` then ``b``."""
    mixed: dict[str, float] = {}
    for viseme, weight in a:
        mixed[viseme] = mixed.get(viseme, 0.0) + (1.0 - s) * weight
    for viseme, weight in b:
        mixed[viseme] = mixed.get(viseme, 0.0) + s * weight
    return tuple((v, w) for v, w in mixed.items() if w > 0.0)


def drawn_states(exposures: Sequence[Exposure]) -> list[Weights]:
    """The states of ``exposures`` in the order they are drawn (what the steps are between)."""
    return [row for exposure in exposures for row, _ in exposure]


def render_learned(
    model: Any,
    timeline: Timeline,
    params: CoarticulationParams,
    *,
    workers: int | None = None,
    morpher: MultiMorpher | None = None,
    weights: Sequence[Weights] | None = None,
    exposures: Sequence[Exposure] | None = None,
    region: Box | None = None,
) -> Iterator[np.ndarray]:
    """The frames of ``timeline`` with the learned coarticulation, in order.

    Each frame's weights come from :func:`miketalk.draw.coarticulation.frame_weights`
    (the timeline's keyframes and frame times; its transitions and alphas are
    not used) and are drawn by :meth:`MultiMorpher.frame`.

    Parameters
    ----------
    model : miketalk.model.face.Model
        Its images and morphs (a :class:`~miketalk.model.morphs.Morphs`).
    timeline : Timeline
    params : CoarticulationParams
        E.g. the model's :attr:`~miketalk.model.face.Model.coarticulation`.
    workers : int, optional
        Threads drawing frames (default the model's :data:`RENDER_WORKERS`);
        the frames do not depend on it.
    morpher : MultiMorpher, optional
        Reused between calls (keeps its flows).
    weights : sequence of Weights, optional
        ``frame_weights(timeline, params)`` when the caller has them already.
    exposures : sequence of Exposure, optional
        Each frame's drawn states (:func:`learned_exposures`), averaged into it; given,
        ``weights`` is not used. A frame of one state is that state's morph.
    region : tuple of int, optional
        ``(x0, y0, x1, y1)``: only these pixels are read (a frame composited into video,
        :meth:`miketalk.composite.compositor.Compositor.render_region`); a morph of three
        or more visemes is drawn there only (:meth:`MultiMorpher.blend`), the same bytes
        there, the rest of its frame not drawn.
    """
    if exposures is None:
        if weights is None:
            weights = frame_weights(timeline, params)
        exposures = [((row, 1.0),) for row in weights]
    morpher = morpher or MultiMorpher(model)
    workers = RENDER_WORKERS if workers is None else max(1, int(workers))
    draw = _exposure_drawer(morpher, region)
    # read the flows the frames need, in the order they are needed
    needed: list[tuple[str, str]] = []
    for row in drawn_states(exposures):
        if len(row) == 2:
            needed.append((row[0][0], row[1][0]))
        elif len(row) > 2:
            reference = max(row, key=lambda item: item[1])[0]
            needed += [(reference, v) for v, _ in row if v != reference]
    model.prefetch(dict.fromkeys(needed))
    if workers == 1:
        for exposure in exposures:
            yield draw(exposure)
        return
    pending: list[Future] = []
    with ThreadPoolExecutor(workers, thread_name_prefix="miketalk-multimorph") as pool:
        try:
            for exposure in exposures:
                pending.append(pool.submit(draw, exposure))
                if len(pending) > 2 * workers:
                    yield pending.pop(0).result()
            while pending:
                yield pending.pop(0).result()
        finally:
            for future in pending:
                future.cancel()


def _exposure_drawer(morpher: MultiMorpher, region: Box | None = None):
    """Draw one frame's states: the one state's morph, or the average of several, accumulated
    in float32 in order and rounded (as :meth:`miketalk.model.face.Model.exposure`)."""

    def draw(exposure: Exposure) -> np.ndarray:
        if len(exposure) == 1:
            return morpher.frame(exposure[0][0], region=region)
        total = None
        for row, share in exposure:
            image = morpher.frame(row, region=region)
            if total is None:
                total = np.zeros(image.shape, np.float32)
            cv2.addWeighted(image, share, total, 1.0, 0.0, dst=total, dtype=cv2.CV_32F)
        return np.clip(np.rint(total), 0, 255).astype(np.uint8)

    return draw


def render_model_learned(model: Any, timeline: Timeline) -> Iterator[np.ndarray]:
    """:func:`render_learned` with the model's own coarticulation
    (:attr:`miketalk.model.face.Model.coarticulation`).

    The ``(model, timeline)`` signature of
    :data:`miketalk_lab.evaluation.renderers.RENDERERS`; raises
    :class:`~miketalk.errors.MiketalkError` for a model without one.
    """
    return render_learned(model, timeline, model.coarticulation)
