"""The rule that warns when a given text and the recognized words disagree, measured.

``python -m miketalk_lab.bench.disagreement HEARD_CSV [--out OUT]`` reads the recognizer
bench's ``heard.csv`` (:mod:`miketalk_lab.bench.recognizer`: per clip its transcript and what
Whisper heard) and scores each clip's recognized words
(:func:`miketalk.speech.recognize.agree.disagreement`) against its own transcript (``right``)
and against another clip's of the same pool (``wrong``: the clip :data:`OTHER` places further
on, a text given with the wrong recording), then counts how many of each
:data:`~miketalk.speech.recognize.agree.DISAGREEMENT_LIMIT` warns about (a right text warned:
a false alarm; a wrong text not warned: a miss). ``OUT/disagreement.csv`` holds every score.
The recognizer bench runs it on its own ``heard.csv`` (``make bench``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from miketalk_lab.bench.command import bench_parser, run_bench

#: The wrong text of clip k is the transcript of clip k + OTHER of the same pool.
OTHER = 7


def disagreement_table(heard: pd.DataFrame, recognizer: str = "whisper-base") -> pd.DataFrame:
    """Per clip of ``recognizer`` the disagreement of its heard words with the right and a
    wrong transcript (columns pool, clip, kind, disagreement)."""
    from miketalk.speech.recognize.agree import disagreement
    from miketalk.speech.recognize.words import spoken_words

    rows = []
    for pool, g in heard[heard["recognizer"] == recognizer].groupby("pool", sort=False):
        g = g.reset_index(drop=True)
        for i, r in g.iterrows():
            said = spoken_words(str(r["hypothesis"]))
            wrong = g["reference"][(i + OTHER) % len(g)]
            for kind, text in (("right", r["reference"]), ("wrong", wrong)):
                score = disagreement(spoken_words(str(text)), said)
                rows.append({"pool": pool, "clip": r["clip"], "kind": kind, "disagreement": score})
    return pd.DataFrame(rows)


def disagreement_summary(table: pd.DataFrame) -> str:
    """The rule's table: per pool and kind the scores' spread and the share warned about."""
    from miketalk.speech.recognize.agree import DISAGREEMENT_LIMIT

    lines = [
        f"## The disagreement rule (warned above {DISAGREEMENT_LIMIT:g}: the letters that "
        "differ between the text and the recognized words, over the text's letters)",
        "",
        "| pool | text | clips | mean | 5 % | median | 95 % | warned |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (pool, kind), g in table.groupby(["pool", "kind"], sort=False):
        d = g["disagreement"]
        lines.append(
            f"| {pool} | {kind} | {len(d)} | {d.mean():.2f} | {d.quantile(0.05):.2f} | "
            f"{d.median():.2f} | {d.quantile(0.95):.2f} | "
            f"{int((d > DISAGREEMENT_LIMIT).sum())} of {len(d)} |"
        )
    return "\n".join(lines) + "\n"


def measure(heard_csv: Path, out: Path | None) -> str:
    """:func:`disagreement_table` of ``heard_csv`` (written to ``out`` when given); its summary."""
    table = disagreement_table(pd.read_csv(heard_csv, keep_default_na=False))
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "disagreement.csv", index=False, float_format="%.4f")
    return disagreement_summary(table)


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (module docstring)."""
    parser: argparse.ArgumentParser = bench_parser(__name__, __doc__, limit_help="unused")
    parser.add_argument("heard", type=Path, help="the recognizer bench's heard.csv")
    parser.add_argument("--out", type=Path, default=None)
    return run_bench(parser, argv, lambda a: measure(a.heard, a.out))


if __name__ == "__main__":
    sys.exit(main())
