"""The names the workflow's settings take, from the library that defines them.

The lip-sync models and the sampling modes are :mod:`miketalk.lipsync.settings`' enums, the
flow strategies :mod:`miketalk.flow.strategies`'; the workflow spells no model, mode or
strategy of its own (tests/test_vocabulary.py compares the schema with the library). The
names here are the enums' plain string values: they go into params, whose repr must stay
``'paper'``, not an enum's.
"""

from __future__ import annotations

from miketalk.flow.strategies import STRATEGY_NAMES
from miketalk.flow.strategies.direct import STRATEGY as DIRECT_STRATEGY
from miketalk.lipsync.settings import SAMPLINGS, LipsyncModel

__all__ = ["DIRECT", "FITTED_MODELS", "PAPER", "SAMPLINGS", "STRATEGY_NAMES", "TRAINED"]

#: The paper's lip-sync model: each transition all the way from viseme to viseme. The sync
#: sweeps study it, whatever a face's own model.
PAPER: str = LipsyncModel.PAPER.value

#: The lip-sync model drawn from the person's own frames along a trajectory: the one a
#: lipsync trajectory goes with.
TRAINED: str = LipsyncModel.TRAINED.value

#: The lip-sync models fitted to the aligned frames of a face's clips (every one but the
#: paper's): only a face built from clips (or from one video of any speech) has them.
FITTED_MODELS: tuple[str, ...] = tuple(m.value for m in LipsyncModel if m != LipsyncModel.PAPER)

#: The flow strategy of the pyramid-depth sweep's methods (the estimator alone).
DIRECT: str = DIRECT_STRATEGY.name
