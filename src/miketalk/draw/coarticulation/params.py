"""The fitted coarticulation parameters and their file (a model keeps it as its
``coarticulation.json``: :attr:`miketalk.model.face.Model.coarticulation`)."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from miketalk.errors import MiketalkError

#: Format tag of the parameters' file.
FORMAT = "miketalk-coarticulation/1"


#: Default rate of the prior (1/s): a dominance falls to 1/e in 1/12 s (about 2 frames at 25 fps).
PRIOR_RATE = 12.0


#: Anticipation leads tried by :func:`fit` (s).
LEAD_GRID = (-0.04, -0.02, 0.0, 0.02, 0.04, 0.06)


@dataclass(frozen=True)
class CoarticulationParams:
    """Fitted dominance parameters (see the module docstring).

    Attributes
    ----------
    magnitude : dict
        ``viseme -> a_V`` (> 0).
    rate : dict
        ``viseme -> theta_V`` in 1/s (> 0).
    lead : float
        Anticipation ``ell`` in seconds.
    window : float
        Keyframes farther than this from a frame (s) have no dominance over it.
    max_visemes : int
        Most visemes blended in one rendered frame.
    min_weight : float
        Weights under this are dropped from a rendered frame (then renormalized).
    fit : dict
        How the parameters were fitted (losses, frames, clips); informative only.
    """

    magnitude: dict[str, float]
    rate: dict[str, float]
    lead: float = 0.0
    window: float = 0.35
    max_visemes: int = 3
    min_weight: float = 0.05
    fit: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if set(self.magnitude) != set(self.rate):
            raise MiketalkError("coarticulation: magnitude and rate name different visemes")
        for name, values in (("magnitude", self.magnitude), ("rate", self.rate)):
            bad = {v: x for v, x in values.items() if not (math.isfinite(x) and x > 0)}
            if bad:
                raise MiketalkError(f"coarticulation: {name} must be positive, got {bad}")
        if not (math.isfinite(self.lead) and abs(self.lead) < 1.0):
            raise MiketalkError(f"coarticulation: lead must be under 1 s, got {self.lead}")
        if not self.window > 0:
            raise MiketalkError(f"coarticulation: window must be positive, got {self.window}")
        if not (isinstance(self.max_visemes, int) and self.max_visemes >= 1):
            raise MiketalkError(f"coarticulation: max_visemes must be >= 1, not {self.max_visemes}")
        if not 0.0 <= self.min_weight < 0.5:
            raise MiketalkError(
                f"coarticulation: min_weight must be in [0, 0.5), got {self.min_weight}"
            )

    @classmethod
    def prior(
        cls, visemes: Sequence[str], *, rate: float = PRIOR_RATE, **settings: Any
    ) -> CoarticulationParams:
        """Every viseme with ``a = 1`` and ``theta = rate`` (what :func:`fit` starts from)."""
        return cls({v: 1.0 for v in visemes}, {v: float(rate) for v in visemes}, **settings)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form :func:`write_params` writes."""
        return {
            "format": FORMAT,
            "magnitude": dict(sorted(self.magnitude.items())),
            "rate": dict(sorted(self.rate.items())),
            "lead": self.lead,
            "window": self.window,
            "max_visemes": self.max_visemes,
            "min_weight": self.min_weight,
            "fit": self.fit,
        }

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> CoarticulationParams:
        """Parameters from :meth:`to_dict`'s form.

        Raises
        ------
        MiketalkError
            For another format or a missing or malformed field.
        """
        if doc.get("format") != FORMAT:
            raise MiketalkError(f"not {FORMAT} parameters (format {doc.get('format')!r})")
        try:
            return cls(
                magnitude={str(k): float(v) for k, v in doc["magnitude"].items()},
                rate={str(k): float(v) for k, v in doc["rate"].items()},
                lead=float(doc["lead"]),
                window=float(doc["window"]),
                max_visemes=int(doc["max_visemes"]),
                min_weight=float(doc["min_weight"]),
                fit=dict(doc.get("fit", {})),
            )
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise MiketalkError(f"malformed coarticulation parameters: {err!r}") from None


def write_params(params: CoarticulationParams, path: str | os.PathLike[str]) -> Path:
    """Write ``params`` to the file ``path`` (atomically); return the path."""
    from miketalk.media.atomic import write_text_atomic

    path = Path(path)
    write_text_atomic(path, json.dumps(params.to_dict(), indent=1, allow_nan=False))
    return path


def read_params(path: str | os.PathLike[str]) -> CoarticulationParams:
    """The parameters :func:`write_params` wrote to the file ``path``.

    Raises
    ------
    MiketalkError
        If the file cannot be read or the parameters are malformed.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise MiketalkError(f"cannot read {path}: {err}") from None
    return CoarticulationParams.from_dict(doc)
