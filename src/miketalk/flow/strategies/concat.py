"""``concat``: the recording's consecutive flows chained from one viseme's frame to the other's.

CONCATENATION-UP (paper Fig. 11) along the recording, run backwards in time
when the second viseme's frame comes first.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from miketalk.flow.strategies.base import Pair, PairFlows, Recording, Strategy


def concat_flows_of_pair(pair: Pair, recording: Recording) -> PairFlows:
    """Both directions as chains of consecutive flows (:meth:`Recording.fold_from`)."""
    if pair.frame_a == pair.frame_b:
        forward = backward = np.zeros((*pair.image_a.shape[:2], 2), np.float32)
    else:
        forward = recording.fold_from(pair.frame_a)[pair.frame_b]
        backward = recording.fold_from(pair.frame_b)[pair.frame_a]
    return PairFlows(forward, backward, {"chain_length": abs(pair.frame_b - pair.frame_a)})


def all_steps(frames: Sequence[int], n_frames: int, rest: np.ndarray | None) -> list[int]:
    """Every consecutive flow between the first and the last viseme frame."""
    return list(range(min(frames), max(frames))) if frames else []


STRATEGY = Strategy("concat", concat_flows_of_pair, all_steps, contiguous=True)
