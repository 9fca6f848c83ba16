"""The held-out tables of the README: per renderer, mean ± sd over clips, and paired margins.

``python -m miketalk_lab.bench.heldout_table results/metrics/heldout/s1/clips.csv`` prints,
for the face's own model (``--model``, default ``bergen/bridge``), two Markdown tables:

1. per renderer, the mean ± sd over clips of :data:`MEASURES` and the fraction
   of clips whose inner-lip opening lag is within one frame;
2. per renderer, its clip-by-clip difference from ``--against`` (default the
   paper's ``morph``): mean and sd over the clips both have.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

#: The measures tabulated, in column order (``clips.csv`` of the held-out evaluation).
MEASURES = (
    "mouth_lmd",
    "lip_opening_corr_speech",
    "lip_opening_amplitude_speech",
    "eigenlip1_corr_speech",
    "psnr_mouth",
    "sharpness_ratio",
)


def tables(clips: pd.DataFrame, *, model: str, against: str = "morph") -> tuple[str, str]:
    """The two Markdown tables (see the module docstring) of one held-out ``clips.csv``."""
    from miketalk_lab.evaluation.landmark_scores import paired_differences

    rows = clips[clips["model"] == model]
    margins = paired_differences(rows, reference=(against, model), measures=MEASURES)
    both = set(rows.loc[rows["renderer"] == against, "clip"])
    head = "| renderer | clips | " + " | ".join(MEASURES) + " | lag within ±1 |"
    rule = "|---" * (len(MEASURES) + 3) + "|"
    spread, paired = [head, rule], [head.replace(" lag within ±1 |", ""), rule[:-4]]
    for renderer, part in rows.groupby("renderer", sort=False):
        cells = [f"{part[m].mean():.3f} ± {part[m].std(ddof=1):.3f}" for m in MEASURES]
        within = float((part["lip_opening_lag"].abs() <= 1).mean())
        spread.append(f"| {renderer} | {len(part)} | " + " | ".join(cells) + f" | {within:.2f} |")
        if renderer == against:
            continue
        margin = margins.loc[(renderer, model)]
        cells = [
            f"{margin[f'{m}_vs_{against}_mean']:+.3f} (sd {margin[f'{m}_vs_{against}_sd']:.3f})"
            for m in MEASURES
        ]
        n = len(set(part["clip"]) & both)
        paired.append(f"| {renderer} − {against} | {n} | " + " | ".join(cells) + " |")
    return "\n".join(spread), "\n".join(paired)


def main(argv: list[str] | None = None) -> int:
    """Print the tables of a held-out ``clips.csv``; a missing file or model is refused."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.heldout_table")
    parser.add_argument("clips", type=Path, help="a held-out evaluation's clips.csv")
    parser.add_argument("--model", default="bergen/bridge", help="the face's own model")
    parser.add_argument("--against", default="morph", help="the renderer margins are taken to")
    args = parser.parse_args(argv)
    if not args.clips.is_file():
        print(f"error: no such file: {args.clips}", file=sys.stderr)
        return 2
    clips = pd.read_csv(args.clips)
    missing = {args.model} - set(clips.get("model", ()))
    missing |= {args.against} - set(clips.get("renderer", ()))
    if missing:
        print(f"error: {args.clips} has no {', '.join(sorted(missing))}", file=sys.stderr)
        return 2
    spread, paired = tables(clips, model=args.model, against=args.against)
    print(spread, paired, sep="\n\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
