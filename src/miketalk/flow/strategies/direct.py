"""``direct``: the estimator between the two viseme images."""

from __future__ import annotations

from miketalk.flow.strategies.base import Pair, PairFlows, Recording, Strategy, no_steps


def direct_flows(pair: Pair, recording: Recording) -> PairFlows:
    """Both directions estimated between the two viseme images."""
    estimate = recording.estimate
    return PairFlows(estimate(pair.image_a, pair.image_b), estimate(pair.image_b, pair.image_a))


STRATEGY = Strategy("direct", direct_flows, no_steps)
