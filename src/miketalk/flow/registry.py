"""The one registry of flow estimators: names (as config.yaml writes them) -> callables + settings.

Every estimator has the signature ``estimator(image_a, image_b) -> flow`` once
its settings are bound; :func:`get_estimator` binds them.

======================  ===============================================  ==========================
name                    function                                         default settings
======================  ===============================================  ==========================
``bergen``              :func:`~miketalk.flow.bergen.bergen_flow`         its signature's defaults
``dis_ultrafast``       :func:`~miketalk.flow.opencv.dis_flow`            ``preset="ultrafast"``
``dis_fast``            :func:`~miketalk.flow.opencv.dis_flow`            ``preset="fast"``
``dis_medium``          :func:`~miketalk.flow.opencv.dis_flow`            ``preset="medium"``
``farneback``           :func:`~miketalk.flow.opencv.farneback_flow`      its signature's defaults
``deepflow``            :func:`~miketalk.flow.opencv.deepflow_flow`       none
``tvl1``                :func:`~miketalk.flow.opencv.tvl1_flow`           its signature's defaults
======================  ===============================================  ==========================
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.flow.bergen import bergen_flow, check_settings
from miketalk.flow.opencv import (
    check_dis_settings,
    check_farneback_settings,
    check_tvl1_settings,
    deepflow_flow,
    dis_flow,
    farneback_flow,
    tvl1_flow,
)


@dataclass(frozen=True)
class Estimator:
    """A flow estimator with bound settings: ``estimator(image_a, image_b) -> flow``.

    Attributes
    ----------
    name : str
        Registry name.
    function : callable
        ``function(image_a, image_b, **settings) -> (H, W, 2) float32``.
    settings : mapping
        Every keyword setting of ``function``, defaults filled in. Recorded in
        the flow database's file headers.
    check : callable, optional
        ``check(**settings)`` raising MiketalkError for bad values, run when
        settings are bound so that a bad configuration fails before any work.
    """

    name: str
    function: Callable[..., np.ndarray]
    settings: Mapping[str, Any] = field(default_factory=dict)
    check: Callable[..., None] | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))

    def __reduce__(self) -> tuple[Any, ...]:
        # a mappingproxy does not pickle; rebuild from a plain dict (for process pools)
        return (Estimator, (self.name, self.function, dict(self.settings), self.check))

    def __repr__(self) -> str:
        bound = ", ".join(f"{k}={v!r}" for k, v in self.settings.items())
        return f"Estimator({self.name!r}{', ' if bound else ''}{bound})"

    def __call__(self, image_a: np.ndarray, image_b: np.ndarray) -> np.ndarray:
        """The flow from ``image_a`` to ``image_b``: ``image_a(p) ~ image_b(p + flow(p))``."""
        return self.function(image_a, image_b, **self.settings)

    def with_settings(self, **settings: Any) -> Estimator:
        """A copy with some settings replaced.

        Raises
        ------
        MiketalkError
            For a setting the function does not take, listing those it takes.
        """
        known = _keyword_settings(self.function)
        unknown = sorted(set(settings) - set(known))
        if unknown:
            listed = ", ".join(known) if known else "none"
            raise MiketalkError(
                f"flow estimator {self.name!r} has no setting {', '.join(map(repr, unknown))} "
                f"(its settings: {listed})"
            )
        merged = {**self.settings, **settings}
        if self.check is not None:
            self.check(**merged)
        return Estimator(self.name, self.function, merged, self.check)


def _keyword_settings(function: Callable[..., Any]) -> dict[str, Any]:
    """The keyword-only settings of ``function`` with their defaults, in order."""
    return {
        p.name: p.default
        for p in inspect.signature(function).parameters.values()
        if p.kind is inspect.Parameter.KEYWORD_ONLY
    }


def _entry(
    name: str,
    function: Callable[..., np.ndarray],
    check: Callable[..., None] | None = None,
    **overrides: Any,
) -> Estimator:
    return Estimator(name, function, check=check).with_settings(
        **{**_keyword_settings(function), **overrides}
    )


#: Registry name -> estimator with its default settings.
ESTIMATORS: Mapping[str, Estimator] = MappingProxyType(
    {
        e.name: e
        for e in (
            _entry("bergen", bergen_flow, check_settings),
            _entry("dis_ultrafast", dis_flow, check_dis_settings, preset="ultrafast"),
            _entry("dis_fast", dis_flow, check_dis_settings, preset="fast"),
            _entry("dis_medium", dis_flow, check_dis_settings, preset="medium"),
            _entry("farneback", farneback_flow, check_farneback_settings),
            _entry("deepflow", deepflow_flow),
            _entry("tvl1", tvl1_flow, check_tvl1_settings),
        )
    }
)


def get_estimator(name: str, **settings: Any) -> Estimator:
    """The registered estimator ``name`` with ``settings`` overriding its defaults.

    Parameters
    ----------
    name : str
        One of :data:`ESTIMATORS`: ``bergen``, ``dis_ultrafast``, ``dis_fast``,
        ``dis_medium``, ``farneback``, ``deepflow``, ``tvl1``.
    **settings
        Keyword settings of the estimator's function.

    Returns
    -------
    Estimator
        Callable as ``estimator(image_a, image_b) -> flow``.

    Raises
    ------
    MiketalkError
        For an unknown name (listing the known ones), an unknown setting, or
        a bad setting value.

    Examples
    --------
    >>> est = get_estimator("bergen", levels=4)
    >>> est.settings["levels"]
    4
    """
    try:
        estimator = ESTIMATORS[name]
    except (KeyError, TypeError):
        raise MiketalkError(
            f"unknown flow estimator {name!r}; known estimators: {', '.join(ESTIMATORS)}"
        ) from None
    return estimator.with_settings(**settings)


def in_region(
    estimate: Callable[[np.ndarray, np.ndarray], np.ndarray], box: tuple[int, int, int, int]
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``estimate`` run on the box ``(x, y, w, h)`` only, the flow zero everywhere else.

    For a stabilized recording, where nothing outside the lower face moves, this
    gives the same flow at a fraction of the cost: the box must hold everything
    that moves, with a margin, so that the flow is near zero at its edge.
    """
    x, y, w, h = (int(v) for v in box)

    def estimate_in_box(image_a: np.ndarray, image_b: np.ndarray) -> np.ndarray:
        flow = np.zeros((*image_a.shape[:2], 2), np.float32)
        inner = (slice(y, y + h), slice(x, x + w))
        flow[inner] = estimate(
            np.ascontiguousarray(image_a[inner]), np.ascontiguousarray(image_b[inner])
        )
        return flow

    return estimate_in_box
