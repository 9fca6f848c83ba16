"""``mixed``: the paper's mix (§5.2) of a direct and a concatenated flow.

A direct flow from the start viseme to a frame that looks like it and lies
shortly before the end viseme's frame, then the concatenated flow from there
(:func:`miketalk.flow.mixed.mixed_flow`).
"""

from __future__ import annotations

import numpy as np

from miketalk.flow.mixed import mixed_flow
from miketalk.flow.strategies.base import Pair, PairFlows, Recording, Strategy, no_steps


def mixed_flows(pair: Pair, recording: Recording) -> PairFlows:
    """Both directions by the mixed strategy; the chosen intermediate frames go into ``info``."""
    info: dict = {}
    flows = []
    for direction, start_image, end in (
        ("forward", pair.image_a, pair.frame_b),
        ("backward", pair.image_b, pair.frame_a),
    ):
        flow, chose = mixed_flow(
            start_image,
            recording.lazy_frames(),
            end,
            recording.estimate,
            window=recording.window,
            mask=recording.mask,
            chains=recording.chains_to(end),
            support=recording.support,
        )
        info[f"{direction}_intermediate"] = chose.index
        info[f"{direction}_chain"] = end - chose.index
        info[f"{direction}_residual"] = chose.residuals[chose.candidates.index(chose.index)]
        flows.append(flow)
    return PairFlows(*flows, _ordered(info))


def _ordered(info: dict) -> dict:
    """The columns in the order the choices table has always had."""
    keys = ("intermediate", "chain", "residual")
    return {f"{d}_{k}": info[f"{d}_{k}"] for d in ("forward", "backward") for k in keys}


def window_steps(frames, n_frames: int, rest: np.ndarray | None) -> list[int]:
    """None: each window's chains are computed where they are used (:meth:`Recording.chains_to`)."""
    return no_steps(frames, n_frames, rest)


STRATEGY = Strategy("mixed", mixed_flows, window_steps)
