"""A face from one video: GRID clips joined, aligned in pieces, built with ``miketalk build``.

``python -m miketalk.bench.one_video --pool DIR --out OUT [--clips ID ...] [--limit N]
[--build] [--heldout-seconds S]`` joins the pool's clips (``video/<id>.mpg``,
``align/<id>.align``, ``transcripts.txt``; all of them in name order, or the
``--clips`` given, in that order) into one video with its plain transcript and
an SRT of sentence cues (:mod:`miketalk.bench.joined`), then, for each of the
two, cuts the video into utterances (:func:`miketalk.corpus.one_video.segment_video`)
and measures every aligned word's start and end against GRID's timings (as
:mod:`miketalk.bench.aligner` does for single clips). With ``--build``, it also
builds the model from the plain transcript with ``miketalk build`` and reports
each stage's time.

Writes ``OUT/<transcript|subtitles>/segments.json``, ``OUT/boundaries.csv`` and
``OUT/summary.md``, and prints the summary. ``run(out_dir)`` (``python -m
miketalk.bench one_video``) does all of it on ``.bench/config.yaml``'s pool, all
200 clips (10 minutes), with the build.
"""

from __future__ import annotations

import argparse
import io
import json
import pathlib
import subprocess
import sys
import time
from collections.abc import Sequence

import numpy as np
import pandas as pd

from miketalk.bench.command import bench_parser, run_bench
from miketalk.errors import MiketalkError

ROOT = pathlib.Path(__file__).resolve().parents[3]

#: The issue's target: this share of word boundaries within 50 ms of GRID's.
TARGET_WITHIN_50 = 0.90


def boundary_errors(segments: dict, truth: pd.DataFrame) -> pd.DataFrame:
    """Each aligned word's start and end against the truth (``words.tsv`` of the join)."""
    rows = []
    index = 0
    unaligned = {u["index"] for u in segments["unaligned"]}
    placed = [i for i in range(len(truth)) if i not in unaligned]
    for u in segments["utterances"]:
        for word, start, end in u["words"]:
            i = placed[index]
            index += 1
            row = truth.iloc[i]
            if row["word"] != word:
                raise MiketalkError(f"word {i}: aligned {word!r}, the truth says {row['word']!r}")
            for boundary, ours, theirs in (
                ("start", u["start"] + start, row["start"]),
                ("end", u["start"] + end, row["end"]),
            ):
                rows.append(
                    {
                        "clip": row["clip"],
                        "word": word,
                        "index": i,
                        "split": u["split"],
                        "boundary": boundary,
                        "ours_s": round(ours, 5),
                        "grid_s": round(float(theirs), 5),
                        "error_ms": round(1000 * (ours - float(theirs)), 2),
                    }
                )
    return pd.DataFrame(rows)


def _line(name: str, errors: pd.DataFrame, words: int, unaligned: int, seconds: float) -> str:
    e = errors["error_ms"].abs().to_numpy()
    return (
        f"| {name} | {words} | {unaligned} | {len(e)} | {np.median(e):.1f} | "
        f"{np.percentile(e, 90):.1f} | {np.max(e):.0f} | {100 * np.mean(e <= 50 + 1e-6):.1f} % | "
        f"{seconds:.1f} |"
    )


#: The held-out measures compared (``clips.csv`` of the held-out evaluation).
HELDOUT_MEASURES = (
    "psnr_mouth",
    "ssim_mouth",
    "opening_corr_speech",
    "eigenlip1_corr_speech",
    "mouth_lmd",
    "lip_opening_corr_speech",
)


def compare_heldout(
    clips_built: pd.DataFrame,
    video_built: pd.DataFrame,
    segments: dict,
    spans: pd.DataFrame,
    *,
    renderers: Sequence[str] = ("morph", "learned"),
) -> pd.DataFrame:
    """The held-out measures of a model from clips and of one from their joined video, paired.

    ``clips_built`` and ``video_built`` are the held-out ``clips.csv`` tables;
    each test utterance of ``segments`` is paired with the joined clip (``spans``:
    the join's ``clips.tsv``) it overlaps most. Per renderer (the face's own
    model) and measure: both means and standard deviations over the paired clips,
    the mean and sd of the paired difference, and whether the difference's mean
    lies within the clips-built model's spread (one sd).
    """
    pairs = {}
    for u in segments["utterances"]:
        if u["split"] != "test":
            continue
        overlap = np.minimum(u["end"], spans["start"] + spans["duration"]) - np.maximum(
            u["start"], spans["start"]
        )
        pairs[u["id"]] = spans["clip"].iloc[int(np.argmax(overlap))]
    own = clips_built["model"].iloc[0]
    rows = []
    for renderer in renderers:
        a = clips_built[(clips_built["renderer"] == renderer) & (clips_built["model"] == own)]
        b = video_built[(video_built["renderer"] == renderer) & (video_built["model"] == own)]
        if a.empty or b.empty:
            continue
        b = b.assign(clip=b["clip"].map(pairs)).dropna(subset=["clip"]).set_index("clip")
        a = a.set_index("clip").reindex(b.index)
        for measure in (m for m in HELDOUT_MEASURES if m in a and m in b):
            diff = b[measure] - a[measure]
            rows.append(
                {
                    "renderer": renderer,
                    "measure": measure,
                    "clips": int(diff.notna().sum()),
                    "clips_built_mean": a[measure].mean(),
                    "clips_built_sd": a[measure].std(ddof=1),
                    "video_built_mean": b[measure].mean(),
                    "video_built_sd": b[measure].std(ddof=1),
                    "paired_diff_mean": diff.mean(),
                    "paired_diff_sd": diff.std(ddof=1),
                    "within_spread": bool(abs(diff.mean()) <= a[measure].std(ddof=1)),
                }
            )
    return pd.DataFrame(rows)


def main(argv: Sequence[str] | None = None) -> int:
    """Join, align, compare (and build); see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="join the first N clips only")
    parser.add_argument("--pool", type=pathlib.Path, required=True, help="a GRID-style folder")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="folder for the results")
    parser.add_argument("--clips", nargs="+", help="the clips to join, in order")
    parser.add_argument("--heldout-seconds", type=float, default=0.0)
    parser.add_argument("--build", action="store_true", help="also run miketalk build")
    parser.add_argument(
        "--crf", type=int, default=18, help="x264's quality of the joined video (0: lossless)"
    )
    parser.add_argument(
        "--compare",
        nargs=3,
        metavar=("CLIPS_CSV", "VIDEO_CSV", "SEGMENTS"),
        type=pathlib.Path,
        help="instead: compare the held-out clips.csv of a model from the clips with that of "
        "the model from their joined video (its segments.json; the join in --out/joined)",
    )
    return run_bench(parser, argv, _run)


def _compare(args: argparse.Namespace) -> str:
    clips_csv, video_csv, segments = args.compare
    table = compare_heldout(
        pd.read_csv(clips_csv),
        pd.read_csv(video_csv),
        json.loads(segments.read_text()),
        pd.read_csv(args.out / "joined" / "clips.tsv", sep="\t"),
    )
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "heldout_comparison.csv", index=False, float_format="%.4f")
    return table.to_markdown(index=False, floatfmt=".3f") if _has_tabulate() else table.to_string()


def _has_tabulate() -> bool:
    try:
        import tabulate  # noqa: F401
    except ImportError:
        return False
    return True


def _run(args: argparse.Namespace) -> str:
    from miketalk.bench.joined import join_clips

    if args.compare:
        return _compare(args)
    from miketalk.corpus.one_video import segment_video

    pool, out = args.pool, args.out
    ids = args.clips or sorted(p.stem for p in (pool / "video").glob("*.mpg"))
    ids = ids[: args.limit]
    started = time.perf_counter()
    joined = join_clips(
        ids,
        out / "joined",
        media=str(pool / "video" / "{id}.mpg"),
        transcripts=pool / "transcripts.txt",
        timings=str(pool / "align" / "{id}.align"),
        crf=args.crf,
    )
    join_s = time.perf_counter() - started
    truth = pd.read_csv(joined.words, sep="\t", keep_default_na=False, dtype={"word": str})
    lines = [
        "# One video: GRID clips joined, aligned in pieces, against GRID's word timings",
        "",
        f"{len(ids)} clips joined ({sum(b - a for a, b in joined.spans.values()):.0f} s) "
        f"in {join_s:.0f} s (x264 crf {args.crf}); held out: the last {args.heldout_seconds:g} s.",
        "",
        "| script | words | unaligned | boundaries | median ms | p90 ms | max ms | <= 50 ms "
        "| segment s |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    tables = []
    for kind, path in (("transcript", joined.transcript), ("subtitles", joined.subtitles)):
        started = time.perf_counter()
        segments = segment_video(
            joined.video,
            out / kind / "segments.json",
            heldout_seconds=args.heldout_seconds,
            **{kind: path},
        )
        seconds = time.perf_counter() - started
        errors = boundary_errors(segments, truth).assign(script=kind)
        tables.append(errors)
        lines.append(_line(kind, errors, segments["words"], len(segments["unaligned"]), seconds))
    table = pd.concat(tables)
    buffer = io.StringIO()
    table.to_csv(buffer, index=False, lineterminator="\n")
    (out / "boundaries.csv").write_text(buffer.getvalue(), "utf-8")
    if args.build:
        lines += ["", _build(joined, out, args.heldout_seconds)]
    summary = "\n".join(lines) + "\n"
    (out / "summary.md").write_text(summary, "utf-8")
    return summary


def _build(joined, out: pathlib.Path, heldout_seconds: float) -> str:
    """``miketalk build`` on the joined video's transcript, timed; a line of its figures."""
    model = out / "model"
    command = [
        sys.executable, "-m", "miketalk", "build", str(joined.video),
        "--transcript", str(joined.transcript), "-o", str(model), "--force", "--json",
        "--heldout-seconds", str(heldout_seconds),
    ]  # fmt: skip
    started = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True)
    if proc.returncode != 0:
        raise MiketalkError(f"miketalk build failed: {proc.stderr.strip().splitlines()[-1]}")
    result = json.loads(proc.stdout)
    (out / "build.json").write_text(json.dumps(result, indent=1) + "\n", "utf-8")
    stages = ", ".join(f"{k} {v:.0f} s" for k, v in result["stage_seconds"].items())
    return (
        f"miketalk build: {time.perf_counter() - started:.0f} s wall "
        f"({result['utterances']} training utterances; {stages})."
    )


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """The 200 clips of ``.bench/config.yaml``'s pool joined (10 minutes), aligned and built."""
    import yaml

    config = yaml.safe_load((ROOT / ".bench" / "config.yaml").read_text())
    pool = (ROOT / config["faces"]["s1"]["corpus"]["transcripts"]).resolve().parent
    main(["--pool", str(pool), "--out", str(out_dir), "--build"])
    table = pd.read_csv(out_dir / "boundaries.csv")
    figures = {}
    for kind, part in table.groupby("script"):
        figures[f"{kind}_within_50_fraction"] = float((part["error_ms"].abs() <= 50 + 1e-6).mean())
    build = json.loads((out_dir / "build.json").read_text())
    figures["build_seconds"] = float(build["seconds"])
    return figures


if __name__ == "__main__":
    sys.exit(main())
