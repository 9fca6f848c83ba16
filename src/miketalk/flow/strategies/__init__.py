"""Flow strategies: how the flow between two viseme images is made (paper §5.2, and ours).

``direct``  the estimator between the two viseme images
``concat``  the recording's consecutive flows chained (CONCATENATION-UP, Fig. 11)
``mixed``   the paper's mix: direct to a look-alike frame just before the end, then chained
``bridge``  ours: the mixed flow, or a chain through the recording's rest frames where it
            explains the end image better

:data:`STRATEGIES` is the one list: the code, the config check and the rules
read it from here.
"""

from __future__ import annotations

from miketalk.errors import MiketalkError
from miketalk.flow.strategies import bridge, concat, direct, mixed
from miketalk.flow.strategies.base import Pair, PairFlows, Recording, Strategy

STRATEGIES: dict[str, Strategy] = {
    s.name: s for s in (direct.STRATEGY, concat.STRATEGY, mixed.STRATEGY, bridge.STRATEGY)
}

#: Strategy names in their canonical order.
STRATEGY_NAMES: tuple[str, ...] = tuple(STRATEGIES)


def get_strategy(name: str) -> Strategy:
    """The strategy called ``name``.

    Raises
    ------
    MiketalkError
        For an unknown name (the message lists the known ones).
    """
    try:
        return STRATEGIES[name]
    except KeyError:
        raise MiketalkError(
            f"unknown flow strategy {name!r}; use one of {', '.join(STRATEGY_NAMES)}"
        ) from None


__all__ = [
    "STRATEGIES",
    "STRATEGY_NAMES",
    "Pair",
    "PairFlows",
    "Recording",
    "Strategy",
    "get_strategy",
]
