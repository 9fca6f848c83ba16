"""Held-out, plain s1 vs hard s1, over several training draws: the difference the hard video
makes, set against the difference between two models built from equally good clips.

``python -m miketalk_lab.bench.hard_draws --pool DIR --out OUT [--draws 0 1 2] [--train N]
[--test M]`` runs :mod:`miketalk_lab.bench.hard_heldout` once per training draw
(``OUT/draw<K>``; draw 0 the config's training clips, draw K > 0 N other clips of the pool
drawn with seed K, :func:`~miketalk_lab.bench.train_test.draw_training`), every draw on the
same M test clips, the hard clips made once (``OUT/hard_train``, ``OUT/hard_test``, shared).

A model is one draw of its training material: the paper's morph takes 16 frames out of
thousands, so two models of the same talker from different clips, or from the same clips
read a grey level apart, differ in what they choose. One pair of models therefore measures
the hard video's effect plus that choice's. This bench reports, per renderer and measure
(:func:`draws_table`):

- ``hard - plain, draw K``: each draw's pair, clip by clip (as ``hard_heldout`` does);
- ``hard - plain, over the draws``: each clip's measure averaged over the draws' plain
  models and over their hard ones, then paired clip by clip, with its 95 % interval and
  the issue's target (the hard video's effect with the choice averaged over the draws);
- ``plain J - plain K`` and ``hard J - hard K``: two plain models (or two hard ones) from
  different draws, paired on the same clips: how far apart two models from equally good
  material are (the build-to-build spread a one-pair target sits in).

Writes ``OUT/draws.tsv`` and ``OUT/summary.md`` and prints the summary.
"""

from __future__ import annotations

import argparse
import itertools
import math
import pathlib
import sys
from collections.abc import Sequence

import pandas as pd

from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.bench.hard_heldout import PAIRED_MEASURES, REPORTED_RENDERERS, TARGETS
from miketalk_lab.evaluation.paired import paired, target_verdict

#: The measures this bench's summary shows (the issue's two targets).
SUMMARY_MEASURES = ("lip_opening_corr_speech", "mouth_lmd")


def draws_table(tables: dict[int, pd.DataFrame], *,
                renderers: Sequence[str] = REPORTED_RENDERERS,
                measures: Sequence[str] = PAIRED_MEASURES) -> pd.DataFrame:  # fmt: skip
    """The comparisons of the module docstring, one row per comparison, renderer and measure.

    Parameters
    ----------
    tables : dict
        ``draw -> hard_heldout's clips.tsv`` (``clip``, ``model``, ``test``, ``renderer``
        and the measures); the rows used are the plain model on plain clips and the hard
        model on hard clips.
    renderers, measures : sequence of str
        What to compare (those a table lacks are skipped).

    Returns
    -------
    DataFrame
        ``comparison``, ``kind`` (``draw``, ``mean``, ``plain spread``, ``hard spread``),
        ``renderer``, ``measure``, :func:`~miketalk_lab.evaluation.paired.paired`'s figures,
        ``target`` and ``verdict`` (the issue's, on ``draw`` and ``mean`` rows).
    """

    def values(draw: int, kind: str, renderer: str, measure: str) -> pd.Series | None:
        t = tables[draw]
        part = t[(t["model"] == kind) & (t["test"] == kind) & (t["renderer"] == renderer)]
        if measure not in part or part.empty:
            return None
        return part.set_index("clip")[measure].astype(float)

    rows = []

    def add(comparison: str, kind: str, renderer: str, measure: str, a, b, judged: bool):
        row = {"comparison": comparison, "kind": kind, "renderer": renderer, "measure": measure}
        row |= paired(a, b)
        limit = TARGETS.get(measure) if judged else None
        row["target"] = math.nan if limit is None else limit
        row["verdict"] = "" if limit is None else target_verdict(
            row["diff_mean"], row["diff_low"], row["diff_high"], limit
        )  # fmt: skip
        rows.append(row)

    draws = sorted(tables)
    for renderer, measure in itertools.product(renderers, measures):
        got = {(d, k): values(d, k, renderer, measure) for d in draws for k in ("plain", "hard")}
        if any(v is None for v in got.values()):
            continue
        for d in draws:
            add(f"hard - plain, draw {d}", "draw", renderer, measure,
                got[(d, "plain")], got[(d, "hard")], True)  # fmt: skip
        if len(draws) > 1:
            mean = {
                k: pd.concat([got[(d, k)] for d in draws], axis=1, join="inner").mean(axis=1)
                for k in ("plain", "hard")
            }
            add(f"hard - plain, over draws {', '.join(map(str, draws))}", "mean", renderer,
                measure, mean["plain"], mean["hard"], True)  # fmt: skip
        for j, k in itertools.combinations(draws, 2):
            for kind in ("plain", "hard"):
                add(f"{kind} {k} - {kind} {j}", f"{kind} spread", renderer, measure,
                    got[(j, kind)], got[(k, kind)], False)  # fmt: skip
    return pd.DataFrame(rows)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``hard_heldout`` per draw and compare; see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="(unused: see --train and --test)")
    parser.add_argument("--pool", type=pathlib.Path, required=True, help="GRID s1's folder")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="folder for the results")
    parser.add_argument("--draws", type=int, nargs="+", default=[0, 1, 2],
                        help="training draws (default 0 1 2)")  # fmt: skip
    parser.add_argument("--train", type=int, default=60, help="training clips (default 60)")
    parser.add_argument("--test", type=int, default=30, help="held-out clips (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="the room's and motions' seed")
    parser.add_argument("--workers", type=int, default=None, help="miketalk build --workers")

    def check(args: argparse.Namespace) -> str | None:
        if len(set(args.draws)) != len(args.draws) or min(args.draws) < 0:
            return "--draws must be different numbers, 0 or more"
        return None

    return run_bench(parser, argv, _run, check=check)


def _run(args: argparse.Namespace) -> str:
    from miketalk_lab.bench import hard_heldout

    out = args.out
    tables = {}
    for draw in args.draws:
        folder = out / f"draw{draw}"
        (folder / "work").mkdir(parents=True, exist_ok=True)
        for kind in ("hard_train", "hard_test"):  # one hard clip per clip, whatever the draw
            shared, link = (out / kind).resolve(), folder / "work" / kind
            shared.mkdir(parents=True, exist_ok=True)
            if not link.is_symlink():
                link.symlink_to(shared, target_is_directory=True)
        print(f"draw {draw} ...", file=sys.stderr, flush=True)
        command = [
            "--pool", str(args.pool), "--out", str(folder), "--train", str(args.train),
            "--test", str(args.test), "--seed", str(args.seed), "--draw", str(draw),
        ]  # fmt: skip
        if args.workers is not None:
            command += ["--workers", str(args.workers)]
        if hard_heldout.main(command) != 0:
            raise MiketalkError(f"draw {draw} failed: see the lines above")
        tables[draw] = pd.read_csv(folder / "clips.tsv", sep="\t")
    table = draws_table(tables)
    table.to_csv(out / "draws.tsv", sep="\t", index=False, float_format="%.5f")
    summary = _summary(args, table)
    (out / "summary.md").write_text(summary, "utf-8")
    return summary


def _summary(args: argparse.Namespace, table: pd.DataFrame) -> str:
    """The markdown summary: the issue's two measures, every comparison."""
    lines = [
        "# Held-out: plain s1 vs hard s1 over training draws",
        "",
        f"Draws {', '.join(map(str, args.draws))}: {args.train} training clips each, the "
        f"same {args.test} held-out clips; hard: seed {args.seed}, 1280x720. Each draw's "
        "own tables: `draw<K>/summary.md`.",
        "",
        "| comparison | renderer | measure | clips | B - A mean (sd) | 95 % interval | target "
        "| verdict |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    shown = table[table["measure"].isin(SUMMARY_MEASURES)]
    for r in shown.sort_values(["measure", "renderer"], kind="stable").itertuples():
        target = "" if not math.isfinite(r.target) else f"{r.target:g}"
        lines.append(
            f"| {r.comparison} | {r.renderer} | {r.measure} | {r.clips} | "
            f"{r.diff_mean:+.3f} ({r.diff_sd:.3f}) | [{r.diff_low:+.3f}, {r.diff_high:+.3f}] "
            f"| {target} | {r.verdict} |"
        )
    lines += ["", "Every measure: `draws.tsv`.", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
