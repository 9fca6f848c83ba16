"""``bridge``: ours. The mixed flow, or a bridge through the recording's rest frames.

    C_{A,B} = concat( C_{a, r_a}, C_{r_a, r_b}, C_{r_b, b} )

with ``a``, ``b`` the frames of visemes A and B, ``r_a``, ``r_b`` the rest frames
nearest to them (:mod:`miketalk.corpus.rest` says how they are found), the outer
two concatenated consecutive flows of the recording and the middle one direct
flow between two rest frames. The bridge replaces the mixed flow of the same
method only where it explains the end image better (a smaller residual, the
mixed strategy's own criterion): a chain through the closed rest pose loses
what the lips hide there (teeth, tongue), so open-to-open pairs keep the mixed
flow.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from miketalk.corpus.rest import nearest_rest
from miketalk.flow.concat import concatenate_up_flows
from miketalk.flow.mixed import warp_residual
from miketalk.flow.strategies.base import Pair, PairFlows, Recording, Strategy
from miketalk.flow.strategies.mixed import mixed_flows


def bridge_flow(recording: Recording, start: int, rest_start: int, rest_end: int, end: int):
    """``C_{start,end}`` through the rest frames ``rest_start`` and ``rest_end``.

    CONCATENATION-UP is a left fold, so the fold of the first leg,
    ``C_{start, rest_start}``, is computed once per start frame and continued
    from there: the same numbers as folding the whole chain.
    """
    flows = []
    if rest_start != rest_end:
        flows.append(recording.estimate(recording.frame(rest_start), recording.frame(rest_end)))
    flows += recording.steps(rest_end, end)
    first = recording.fold_of_steps(start, rest_start)
    if first is None:
        return recording.chain(flows, start)
    return concatenate_up_flows([first, *flows], recording.support) if flows else first.copy()


def bridge_flows(pair: Pair, recording: Recording) -> PairFlows:
    """The mixed flows, each replaced by its bridge where the bridge's residual is smaller."""
    mask = recording.mask
    if recording.mixed is not None:  # the mixed database of the same method, made by its own job
        forward = recording.mixed.flow(pair.source, pair.target)
        backward = recording.mixed.flow(pair.target, pair.source)
        info = {
            "forward_residual": warp_residual(pair.image_a, pair.image_b, forward, mask),
            "backward_residual": warp_residual(pair.image_b, pair.image_a, backward, mask),
        }
        result = PairFlows(forward, backward, info)
    else:
        result = mixed_flows(pair, recording)
    info = result.info
    rest_a, rest_b = (nearest_rest(f, recording.rest) for f in (pair.frame_a, pair.frame_b))
    info.update(rest_a=rest_a, rest_b=rest_b)
    for direction, start, image_s, image_e, path in (
        ("forward", pair.frame_a, pair.image_a, pair.image_b, (rest_a, rest_b, pair.frame_b)),
        ("backward", pair.frame_b, pair.image_b, pair.image_a, (rest_b, rest_a, pair.frame_a)),
    ):
        flow = bridge_flow(recording, start, *path)
        residual = warp_residual(image_s, image_e, flow, mask)
        use = residual < info[f"{direction}_residual"]
        info[f"{direction}_bridged"] = use
        if use:
            info[f"{direction}_residual"] = residual
            info[f"{direction}_chain"] = abs(start - path[0]) + abs(path[2] - path[1])
            setattr(result, direction, flow)
    return result


def rest_steps(frames: Sequence[int], n_frames: int, rest: np.ndarray | None) -> list[int]:
    """The consecutive flows between each viseme frame and its nearest rest frame."""
    spans = [sorted((f, nearest_rest(f, rest))) for f in frames]
    return sorted({k for lo, hi in spans for k in range(lo, hi)})


STRATEGY = Strategy("bridge", bridge_flows, rest_steps, needs_rest=True, refines="mixed")
