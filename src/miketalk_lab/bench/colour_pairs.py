"""Two runs of the held-out weekly-address bench, each dubbed with its own colour match,
paired clip by clip.

    python -m miketalk_lab.bench.colour_pairs OFFSET/clips.csv GAIN/clips.csv

Reads :mod:`miketalk_lab.bench.anyone`'s ``clips.csv`` of two runs (``--colour offset`` and
``--colour gain``: the same models, clips and renderers) and prints, per renderer, each
measure's mean in both, and the paired difference (second minus first): its mean, sd, 95 %
interval (normal, over the clips) and the clips where the second is nearer the real lips
(for ``lip_dE`` and ``lip_dE_sd``: smaller; for the signed ``lip_dL``, ``lip_da``,
``lip_db``: nearer 0).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

#: The measures paired: the lips' colour against the real lips', then the mouth's motion.
#: ``lip_dE_sd``: how much the lips' distance from his changes from frame to frame over a
#: clip (frames drawn from other days' light change colour).
MEASURES = ("lip_dE", "lip_dL", "lip_da", "lip_db", "lip_dE_sd", "r", "amplitude", "lmd")


def colour_pairs(first: pd.DataFrame, second: pd.DataFrame) -> pd.DataFrame:
    """One row per renderer and measure (module docstring)."""
    rows = []
    for renderer in [r for r in first["renderer"].unique() if r != "real_late1"]:
        a = first[first["renderer"] == renderer].set_index("clip")
        b = second[second["renderer"] == renderer].set_index("clip")
        common = a.index.intersection(b.index)
        for m in (m for m in MEASURES if m in a and m in b):
            x, y = a.loc[common, m].astype(float), b.loc[common, m].astype(float)
            d = y - x
            nearer = y < x if m in ("lip_dE", "lip_dE_sd", "lmd") else y.abs() < x.abs()
            half = 1.96 * d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else np.nan
            rows.append({
                "renderer": renderer, "measure": m, "clips": len(d), "first": x.mean(),
                "second": y.mean(), "diff": d.mean(), "diff_sd": d.std(ddof=1),
                "ci_low": d.mean() - half, "ci_high": d.mean() + half,
                "second_nearer": int(nearer.sum()),
            })  # fmt: skip
    return pd.DataFrame(rows)


def markdown(table: pd.DataFrame) -> str:
    """:func:`colour_pairs` as a Markdown table."""
    lines = ["| renderer | measure | clips | first | second | second - first (sd) | 95 % | "
             "second nearer |", "|---" * 8 + "|"]  # fmt: skip
    for r in table.itertuples():
        lines.append(
            f"| {r.renderer} | {r.measure} | {r.clips} | {r.first:.2f} | {r.second:.2f} | "
            f"{r.diff:+.2f} ({r.diff_sd:.2f}) | [{r.ci_low:+.2f}, {r.ci_high:+.2f}] | "
            f"{r.second_nearer} of {r.clips} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.colour_pairs")
    parser.add_argument("first", type=Path)
    parser.add_argument("second", type=Path)
    args = parser.parse_args(argv)
    print(markdown(colour_pairs(pd.read_csv(args.first), pd.read_csv(args.second))), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
