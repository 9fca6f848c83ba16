"""A face from one video: GRID clips joined, aligned in pieces, built with ``miketalk build``.

``python -m miketalk_lab.bench.one_video --pool DIR --out OUT [--clips ID ... | --face F]
[--limit N] [--build [--build-from subtitles]] [--heldout-seconds S]`` joins the
pool's clips (``video/<id>.mpg``, ``align/<id>.align``, ``transcripts.txt``; all
of them in name order, the ``--clips`` given, in that order, or the training
clips of face F of ``--config``) into one video with its plain transcript and an
SRT of sentence cues (:mod:`miketalk_lab.bench.joined`), then, for each of the two,
cuts the video into utterances (:func:`miketalk.corpus.one_video.segment_video`)
and measures every aligned word's start and end against GRID's timings (as
:mod:`miketalk_lab.bench.aligner` does for single clips). With ``--build``, it also
builds the model from the plain transcript (or the SRT) with ``miketalk build``
and reports each stage's time; with ``--face`` too, the model is measured on the
face's held-out clips (the clip files) and compared, clip by clip, with the
clips-built face's own held-out measures (``--against``, default
``results/metrics/heldout/F/clips.csv`` of ``make run``), and the two corpora's
phones are compared (:mod:`miketalk_lab.bench.video_vs_clips`).

Writes ``OUT/<transcript|subtitles>/segments.json``, ``OUT/boundaries.csv``,
``OUT/summary.md`` (and with ``--face``: ``OUT/heldout/``,
``OUT/heldout_comparison.csv``, ``OUT/phones.csv``), and prints the summary.
``run(out_dir)`` (``python -m miketalk_lab.bench one_video``) does all of it on
``.bench/config.yaml``'s pool, all 200 clips (10 minutes), with the build.
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

from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench

ROOT = pathlib.Path(__file__).resolve().parents[3]

#: The issue's target: this share of word boundaries within 50 ms of GRID's.
TARGET_WITHIN_50 = 0.90


def within_50(errors_ms) -> float:
    """The share of boundary errors (ms, either sign) within 50 ms."""
    return float((np.abs(np.asarray(errors_ms, float)) <= 50 + 1e-6).mean())


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
        f"{np.percentile(e, 90):.1f} | {np.max(e):.0f} | {100 * within_50(e):.1f} % | "
        f"{seconds:.1f} |"
    )


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
    parser.add_argument("--build-from", choices=("transcript", "subtitles"), default="transcript")
    parser.add_argument("--face", help="join this face's training clips; compare its models")
    parser.add_argument("--config", type=pathlib.Path, default=ROOT / "config.yaml")
    parser.add_argument("--against", type=pathlib.Path, help="the clips-built face's clips.csv")
    return run_bench(parser, argv, _run)


def _run(args: argparse.Namespace) -> str:
    from miketalk.corpus.one_video import segment_video
    from miketalk_lab.bench.joined import join_clips

    pool, out = args.pool, args.out
    face = _face(args.config, args.face) if args.face else None
    ids = args.clips or (face["corpus"]["train"] if face else None)
    ids = ids or sorted(p.stem for p in (pool / "video").glob("*.mpg"))
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
        lines += ["", _build(joined, out, args.heldout_seconds, args.build_from)]
        if face is not None:
            lines += ["", _versus_clips(args, face, joined)]
    summary = "\n".join(lines) + "\n"
    (out / "summary.md").write_text(summary, "utf-8")
    return summary


def _build(joined, out: pathlib.Path, heldout_seconds: float, script: str) -> str:
    """``miketalk build`` on the joined video's transcript (or SRT), timed; a line of its figures.

    The corpus is kept (``OUT/corpus``) for the held-out comparison.
    """
    import shutil

    model, corpus = out / "model", out / "corpus"
    shutil.rmtree(corpus, ignore_errors=True)
    command = [
        str(pathlib.Path(sys.executable).parent / "miketalk"), "build", str(joined.video),
        f"--{script}", str(getattr(joined, script)), "-o", str(model), "--force", "--json",
        "--heldout-seconds", str(heldout_seconds), "--keep-corpus", str(corpus),
    ]  # fmt: skip
    started = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True)
    if proc.returncode != 0:
        raise MiketalkError(f"miketalk build failed: {proc.stderr.strip().splitlines()[-1]}")
    result = json.loads(proc.stdout)
    (out / "build.json").write_text(json.dumps(result, indent=1) + "\n", "utf-8")
    stages = ", ".join(f"{k} {v:.0f} s" for k, v in result["stage_seconds"].items())
    return (
        f"miketalk build --{script}: {time.perf_counter() - started:.0f} s wall "
        f"({result['utterances']} training utterances; {stages})."
    )


def _face(config_path: pathlib.Path, name: str) -> dict:
    """Face ``name`` of a workflow config, with the config's morph and grouping beside it."""
    import yaml

    config = yaml.safe_load(config_path.read_text())
    if name not in config.get("faces", {}):
        raise MiketalkError(f"{config_path}: no face {name}")
    face = dict(config["faces"][name])
    face["morph_options"] = {**config.get("morph", {}), **face.get("morph", {})}
    face["grouping"] = config.get("visemes", {}).get("grouping", {})
    flow = config.get("flow", {})
    face["model_name"] = f"{flow.get('method', 'bergen')}/{flow.get('strategy', 'bridge')}"
    face["root"] = config_path.resolve().parent
    return face


def _versus_clips(args: argparse.Namespace, face: dict, joined) -> str:
    """The built model on the face's held-out clips against the clips-built one; the phones."""
    from miketalk.corpus.clip_sources import clip_sources
    from miketalk_lab.bench.video_vs_clips import compare_heldout, heldout_of_model, phone_errors

    out, root, corpus = args.out, face["root"], face["corpus"]
    clips = clip_sources(
        corpus["test"],
        media=str(root / corpus["media"]),
        transcripts=root / corpus["transcripts"],
        timings=str(root / corpus["timings"]),
    )
    against = args.against or root / "results/metrics/heldout" / args.face / "clips.csv"
    if not against.is_file():
        raise MiketalkError(f"{against} not found: run the workflow for face {args.face} first")
    started = time.perf_counter()
    video_built = heldout_of_model(
        out / "model", out / "corpus", clips, out / "heldout", name=face["model_name"],
        morph=face["morph_options"], grouping=face["grouping"],
    )  # fmt: skip
    seconds = time.perf_counter() - started
    table = compare_heldout(pd.read_csv(against), video_built, model=face["model_name"])
    table.to_csv(out / "heldout_comparison.csv", index=False, float_format="%.4f")
    segments = json.loads((out / "model" / "build" / "segments.json").read_text())
    spans = pd.read_csv(joined.clips, sep="\t")
    clips_corpus = against.parents[3] / "corpus" / args.face
    phones = phone_errors(out / "corpus", segments, clips_corpus, spans)
    phones.to_csv(out / "phones.csv", index=False)
    same = phones.drop_duplicates("utterance")["same_phones"]
    error = phones["error_ms"].abs().dropna()
    lines = [
        f"Phones against {clips_corpus}: {int(same.sum())} of {len(same)} utterances with the "
        f"same spoken phones; {len(error)} boundaries, median {error.median():.1f} ms, "
        f"{100 * within_50(error):.1f} % within 50 ms, max {error.max():.0f} ms.",
        "",
        f"Held out ({len(clips)} clips of face {args.face}, {seconds:.0f} s), the model from "
        f"the video against {against}, paired by clip:",
        "",
        table.to_string(index=False, float_format=lambda v: f"{v:.3f}"),
    ]
    return "\n".join(lines)


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """The 200 clips of ``.bench/config.yaml``'s pool joined (10 minutes), aligned and built."""
    import yaml

    config = yaml.safe_load((ROOT / ".bench" / "config.yaml").read_text())
    pool = (ROOT / config["faces"]["s1"]["corpus"]["transcripts"]).resolve().parent
    main(["--pool", str(pool), "--out", str(out_dir), "--build"])
    table = pd.read_csv(out_dir / "boundaries.csv")
    figures = {}
    for kind, part in table.groupby("script"):
        figures[f"{kind}_within_50_fraction"] = within_50(part["error_ms"])
        figures[f"{kind}_within_50_target_met"] = float(
            figures[f"{kind}_within_50_fraction"] >= TARGET_WITHIN_50
        )
    build = json.loads((out_dir / "build.json").read_text())
    figures["build_seconds"] = float(build["seconds"])
    return figures


if __name__ == "__main__":
    sys.exit(main())
