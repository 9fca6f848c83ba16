"""Two sets of values of one measure compared clip by clip: the paired difference's mean,
spread and 95 % Student-t interval, and a verdict against a target."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["paired", "target_verdict"]


def paired(a: pd.Series, b: pd.Series) -> dict[str, float]:
    """Two models' values of one measure, paired by index (the clip), ``b - a``: ``clips``
    (pairs where both are finite), ``a_mean``, ``a_sd``, ``b_mean``, ``b_sd``, ``diff_mean``,
    ``diff_sd`` and the mean difference's 95 % Student-t interval (``diff_low``,
    ``diff_high``; NaN for fewer than two pairs)."""
    from scipy import stats

    both = pd.concat({"a": a, "b": b}, axis=1, join="inner").astype(float)
    both = both[np.isfinite(both).all(axis=1)]
    n = len(both)
    diff = both["b"] - both["a"]
    half = stats.t.ppf(0.975, n - 1) * diff.std(ddof=1) / math.sqrt(n) if n >= 2 else math.nan
    mean = float(diff.mean()) if n else math.nan
    out = {"clips": n}
    for name, values in (("a", both["a"]), ("b", both["b"]), ("diff", diff)):
        out[f"{name}_mean"] = float(values.mean()) if n else math.nan
        out[f"{name}_sd"] = float(values.std(ddof=1)) if n >= 2 else math.nan
    return out | {"diff_low": mean - float(half), "diff_high": mean + float(half)}


def target_verdict(diff_mean: float, low: float, high: float, limit: float) -> str:
    """``met`` when the mean difference is within ``limit``; ``met (interval too)`` when
    its whole 95 % interval is; ``not met`` otherwise."""
    if not abs(diff_mean) <= limit:
        return "not met"
    if -limit <= low and high <= limit:
        return "met (interval too)"
    return "met (mean only)"
