"""Frames drawn with a model's learned coarticulation (:mod:`miketalk.draw.coarticulation`).

Each frame's viseme weights come from the fitted dominance functions at the
frame's middle; the N-way morph (:class:`miketalk.render.multimorph.MultiMorpher`)
draws them.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from miketalk.draw.coarticulation import CoarticulationParams, frame_weights, read_params
from miketalk.lipsync.timeline import Timeline
from miketalk.model.face import RENDER_WORKERS, Model
from miketalk.render.multimorph import MultiMorpher, Weights

__all__ = ["render_learned", "render_model_learned"]


def render_learned(
    model: Model,
    timeline: Timeline,
    params: CoarticulationParams,
    *,
    workers: int | None = None,
    morpher: MultiMorpher | None = None,
    weights: Sequence[Weights] | None = None,
) -> Iterator[np.ndarray]:
    """The frames of ``timeline`` with the learned coarticulation, in order.

    Each frame's weights come from :func:`miketalk.draw.coarticulation.frame_weights`
    (the timeline's keyframes and frame times; its transitions and alphas are
    not used) and are drawn by :meth:`MultiMorpher.frame`.

    Parameters
    ----------
    model : Model
    timeline : Timeline
    params : CoarticulationParams
        E.g. :func:`miketalk.draw.coarticulation.read_params` of the model's directory.
    workers : int, optional
        Threads drawing frames (default the model's :data:`RENDER_WORKERS`);
        the frames do not depend on it.
    morpher : MultiMorpher, optional
        Reused between calls (keeps its flows).
    weights : sequence of Weights, optional
        ``frame_weights(timeline, params)`` when the caller has them already.
    """
    if weights is None:
        weights = frame_weights(timeline, params)
    morpher = morpher or MultiMorpher(model)
    workers = RENDER_WORKERS if workers is None else max(1, int(workers))
    # read the flows the frames need, in the order they are needed
    needed: list[tuple[str, str]] = []
    for row in weights:
        if len(row) == 2:
            needed.append((row[0][0], row[1][0]))
        elif len(row) > 2:
            reference = max(row, key=lambda item: item[1])[0]
            needed += [(reference, v) for v, _ in row if v != reference]
    model.prefetch(dict.fromkeys(needed))
    if workers == 1:
        for row in weights:
            yield morpher.frame(row)
        return
    pending: list[Future] = []
    with ThreadPoolExecutor(workers, thread_name_prefix="miketalk-multimorph") as pool:
        try:
            for row in weights:
                pending.append(pool.submit(morpher.frame, row))
                if len(pending) > 2 * workers:
                    yield pending.pop(0).result()
            while pending:
                yield pending.pop(0).result()
        finally:
            for future in pending:
                future.cancel()


def render_model_learned(model: Model, timeline: Timeline) -> Iterator[np.ndarray]:
    """:func:`render_learned` with the parameters fitted into the model's directory.

    The ``(model, timeline)`` signature of
    :data:`miketalk_lab.evaluation.renderers.RENDERERS`; raises
    :class:`~miketalk.errors.MiketalkError` for a model without
    ``coarticulation.json`` (:func:`miketalk.draw.coarticulation.read_params`).
    """
    return render_learned(model, timeline, read_params(model.directory))
