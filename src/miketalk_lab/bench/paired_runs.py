"""Two runs' held-out tables paired clip by clip: which renderers' measures are equal, and for
one renderer each measure's paired difference (after - before) with its 95 % interval.

    python -m miketalk_lab.bench.paired_runs BEFORE/clips.csv AFTER/clips.csv --renderer learned

For a change that should move one renderer only (issue 49: the coarticulation fit's
optimizer moves ``learned``): the others must be equal, the one paired
(:func:`miketalk_lab.evaluation.paired.paired`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk_lab.evaluation.paired import paired

#: The held-out measures paired (as :mod:`miketalk_lab.bench.heldout_table` shows them).
MEASURES = (
    "mouth_lmd",
    "lip_opening_corr_speech",
    "lip_opening_amplitude_speech",
    "eigenlip1_corr_speech",
)
KEY = ["clip", "renderer", "model"]


def equal_renderers(before: pd.DataFrame, after: pd.DataFrame) -> dict[str, float]:
    """Each renderer's largest absolute difference of any numeric measure (0: equal)."""
    b, a = before.set_index(KEY).sort_index(), after.set_index(KEY).sort_index()
    if not b.index.equals(a.index):
        raise ValueError("the two tables hold different clips, renderers or models")
    numeric = [c for c in b.columns if pd.api.types.is_numeric_dtype(b[c])]
    out = {}
    for renderer in sorted(set(b.index.get_level_values("renderer"))):
        x = b.xs(renderer, level="renderer")[numeric].to_numpy(float)
        y = a.xs(renderer, level="renderer")[numeric].to_numpy(float)
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        out[renderer] = 0.0 if same.all() else float(np.nanmax(np.abs(x - y)))
    return out


def paired_table(before: pd.DataFrame, after: pd.DataFrame, renderer: str) -> pd.DataFrame:
    """One row per measure of :data:`MEASURES`: ``renderer``'s values paired by clip."""

    def of(table: pd.DataFrame) -> pd.DataFrame:
        return table[table["renderer"] == renderer].set_index("clip")

    b, a = of(before), of(after)
    return pd.DataFrame([{"measure": m} | paired(b[m], a[m]) for m in MEASURES])


def main(argv: list[str] | None = None) -> int:
    """Print both tables (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--renderer", default="learned")
    args = parser.parse_args(argv)
    before, after = pd.read_csv(args.before), pd.read_csv(args.after)
    for renderer, worst in equal_renderers(before, after).items():
        print(f"{renderer:24s} {'equal' if worst == 0 else f'largest difference {worst:.6g}'}")
    print(paired_table(before, after, args.renderer).round(4).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
