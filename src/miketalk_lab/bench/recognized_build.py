"""A face built from recognized words against one built from its transcript, held out on s1.

``python -m miketalk_lab.bench.recognized_build --out OUT [--config .bench/config.yaml]
[--train N] [--every K] [--limit N] [--builds transcript,recognized,reordered]``

Issue 53's first target. Clips of face ``s1`` of ``--config`` (every ``K``-th of its training
clips, ``N`` of them: 8 by default, some 24 s, the issue 52 case of a short video) are joined
into one video with their transcript (:func:`miketalk_lab.bench.joined.join_clips`), and that
video is built twice with ``miketalk build``, nothing of it held back: with ``--transcript``
(``transcript``), and with no script at all (``recognized``: its words heard by the
recognizer, :mod:`miketalk.corpus.heard_script`). Both models are measured on the face's
held-out clips (``test``: never read by either; ``--limit``: the first N), each in its own
corpus's frame (:func:`miketalk_lab.bench.video_vs_clips.heldout_of_model`: the held-out
evaluation of every lip-sync model, drawn along each clip's own phones), and paired clip by
clip, recognized minus transcript (:func:`paired`): per renderer and measure the mean
difference, its sd and 95 % interval, and the clips within the target's bound.

``--builds`` names the builds, the first the one every other is paired against. ``reordered``
is the control of the bound's own noise: the same clips joined in another order (the second
half first), built with their transcript, so ``reordered`` minus ``transcript`` is how far two
transcript builds of one person's same frames, cut differently, move each measure.

Writes ``OUT/joined/``, ``OUT/{transcript,recognized}/{model,corpus,heldout}/``,
``OUT/{transcript,recognized}/build.log``, ``OUT/paired.csv`` and ``OUT/summary.md``; a model
or a held-out table already there is kept (delete it to make it again). ``run(out_dir)``
(``python -m miketalk_lab.bench recognized_build``) runs it on ``.bench/config.yaml``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench

ROOT = Path(__file__).resolve().parents[3]

#: The issue's bounds on recognized minus transcript (absolute), per held-out measure.
BOUNDS = {"lip_opening_corr_speech": 0.05, "mouth_lmd": 0.15, "lip_opening_amplitude_speech": 0.05}

#: The builds: the words of ``transcript`` and ``reordered`` are given, ``recognized`` hears
#: them; ``reordered`` joins the same clips in another order (:func:`reordered`).
SCRIPTS = ("transcript", "recognized", "reordered")


def reordered(ids: Sequence[str]) -> list[str]:
    """The same clips in another order: the second half first (a rotation: every clip's
    frames and sound are the same, its place in the video and most of its joins are not)."""
    half = (len(ids) + 1) // 2
    return [*ids[half:], *ids[:half]]


def paired(
    a: pd.DataFrame, b: pd.DataFrame, renderers: Sequence[str], names: Sequence[str] = SCRIPTS[:2]
) -> pd.DataFrame:
    """``b`` minus ``a`` (held-out ``clips.csv`` tables) clip by clip: per renderer and
    :data:`BOUNDS` measure, both means (columns ``transcript`` and ``recognized``), the
    difference's mean, sd, 95 % interval (normal, over the clips) and how many clips lie
    within the bound; ``names`` (``a``'s and ``b``'s build) fill ``base`` and ``build``."""
    rows = []
    for renderer in renderers:
        pa = a[a["renderer"] == renderer].set_index("clip")
        pb = b[b["renderer"] == renderer].set_index("clip")
        common = pa.index.intersection(pb.index)
        for measure, bound in BOUNDS.items():
            if measure not in pa or measure not in pb or common.empty:
                continue
            diff = (pb.loc[common, measure] - pa.loc[common, measure]).dropna()
            half = 1.96 * diff.std(ddof=1) / np.sqrt(len(diff)) if len(diff) > 1 else np.nan
            rows.append({
                "base": names[0], "build": names[1],
                "renderer": renderer, "measure": measure, "clips": len(diff),
                "transcript": pa.loc[common, measure].mean(),
                "recognized": pb.loc[common, measure].mean(),
                "diff_mean": diff.mean(), "diff_sd": diff.std(ddof=1),
                "ci_low": diff.mean() - half, "ci_high": diff.mean() + half,
                "clips_within": int((diff.abs() <= bound).sum()), "bound": bound,
            })  # fmt: skip
    return pd.DataFrame(rows)


def _build(video: Path, out: Path, script: Path | None) -> dict:
    """``miketalk build`` of ``video`` into ``out/model`` (its corpus kept), ``--transcript
    script`` or none; its JSON result (kept in ``out/build.json``)."""
    done = out / "build.json"
    if done.is_file() and (out / "model" / "manifest.json").is_file():
        return json.loads(done.read_text())
    out.mkdir(parents=True, exist_ok=True)
    command = [
        str(Path(sys.executable).parent / "miketalk"), "build", str(video), "-o",
        str(out / "model"), "--force", "--json", "--heldout-seconds", "0",
        "--keep-corpus", str(out / "corpus"),
        *(("--transcript", str(script)) if script is not None else ()),
    ]  # fmt: skip
    started = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True)
    (out / "build.log").write_text(proc.stderr, "utf-8")
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
        raise MiketalkError(f"miketalk build failed ({out.name}): {tail}")
    result = {**json.loads(proc.stdout), "wall_seconds": time.perf_counter() - started}
    done.write_text(json.dumps(result, indent=1) + "\n", "utf-8")
    return result


def _segments(out: Path) -> dict:
    return json.loads((out / "model" / "build" / "segments.json").read_text())


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (the module docstring)."""
    parser = bench_parser(__name__, __doc__, limit_help="the first N held-out clips only")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--config", type=Path, default=ROOT / ".bench" / "config.yaml")
    parser.add_argument("--train", type=int, default=8, help="training clips joined")
    parser.add_argument("--every", type=int, default=5, help="every K-th training clip")
    parser.add_argument(
        "--builds", default="transcript,recognized",
        help=f"the builds, comma-separated, of {', '.join(SCRIPTS)}: the first is the base "
        "every other is paired against",
    )  # fmt: skip
    return run_bench(parser, argv, _work, check=_check)


def _builds(args: argparse.Namespace) -> list[str]:
    return [b.strip() for b in args.builds.split(",") if b.strip()]


def _check(args: argparse.Namespace) -> str | None:
    builds = _builds(args)
    unknown = sorted(set(builds) - set(SCRIPTS))
    if unknown:
        return f"--builds: unknown {', '.join(unknown)} (known: {', '.join(SCRIPTS)})"
    if len(builds) < 2 or len(set(builds)) != len(builds):
        return "--builds needs two or more different builds"
    return None


def _work(args: argparse.Namespace) -> str:
    from miketalk.corpus.clip_sources import clip_sources
    from miketalk_lab.bench.joined import join_clips
    from miketalk_lab.bench.one_video import _face
    from miketalk_lab.bench.video_vs_clips import heldout_of_model

    face = _face(args.config, "s1")
    root, corpus = args.config.resolve().parents[1], face["corpus"]  # relative to the project
    ids = list(corpus["train"])[:: args.every][: args.train]
    test = list(corpus["test"])[: args.limit]
    names = _builds(args)
    sources = {"media": str(root / corpus["media"]), "transcripts": root / corpus["transcripts"],
               "timings": str(root / corpus["timings"])}  # fmt: skip
    joined = join_clips(ids, args.out / "joined", **sources)
    cuts = {"transcript": joined, "recognized": joined}
    if "reordered" in names:
        cuts["reordered"] = join_clips(reordered(ids), args.out / "joined_reordered", **sources)
    clips = clip_sources(test, media=str(root / corpus["media"]),
                         transcripts=root / corpus["transcripts"],
                         timings=str(root / corpus["timings"]))  # fmt: skip
    tables, builds = {}, {}
    for name in names:
        out = args.out / name
        script = None if name == "recognized" else cuts[name].transcript
        builds[name] = _build(cuts[name].video, out, script)
        held = out / "heldout" / "clips.csv"
        tables[name] = (
            pd.read_csv(held) if held.is_file() and args.limit is None
            else heldout_of_model(out / "model", out / "corpus", clips, out / "heldout",
                                  name=face["model_name"], morph=face["morph_options"],
                                  grouping=face["grouping"])
        )  # fmt: skip
    base = tables[names[0]]
    table = pd.concat([
        paired(base, tables[name], sorted(set(base.renderer) & set(tables[name].renderer)),
               (names[0], name))
        for name in names[1:]
    ], ignore_index=True)  # fmt: skip
    table.to_csv(args.out / "paired.csv", index=False, float_format="%.4f")
    return _summary(args, ids, test, builds, table)


def _summary(args, ids, test, builds: dict, table: pd.DataFrame) -> str:
    lines = [
        f"# Builds of the same s1 video against {_builds(args)[0]}: {len(ids)} training clips "
        f"joined ({' '.join(ids)}), {len(test)} held-out clips", "",
    ]  # fmt: skip
    for name in builds:
        seg = _segments(args.out / name)
        left = len(seg.get("unaligned", ())) + len(seg.get("not_confident", ()))
        lines.append(
            f"- {name}: {seg.get('words', '?')} words placed, {left} left out, "
            f"{len(seg.get('utterances', ()))} utterances; built in "
            f"{builds[name]['wall_seconds']:.0f} s; words from {seg.get('words_from', 'given')}"
        )
    lines += ["", "| build - base | renderer | measure | clips | base | build | build - base "
              "(sd) | 95 % | clips within bound |", "|---" * 9 + "|"]  # fmt: skip
    for _, r in table.iterrows():
        lines.append(
            f"| {r.build} - {r.base} | {r.renderer} | {r.measure} | {r.clips} "
            f"| {r.transcript:.3f} | {r.recognized:.3f} "
            f"| {r.diff_mean:+.3f} ({r.diff_sd:.3f}) | [{r.ci_low:+.3f}, {r.ci_high:+.3f}] "
            f"| {r.clips_within} (±{r.bound:g}) |"
        )
    summary = "\n".join(lines) + "\n"
    (args.out / "summary.md").write_text(summary, "utf-8")
    return summary


def run(out_dir: Path) -> dict[str, float]:
    """``.bench/config.yaml``'s s1, 8 training clips, every held-out clip: per renderer and
    measure the mean of recognized minus transcript."""
    if main(["--out", str(out_dir)]) != 0:
        raise MiketalkError("the recognized_build bench failed")
    table = pd.read_csv(out_dir / "paired.csv")
    return {f"{r.renderer}_{r.measure}_diff": float(r.diff_mean) for r in table.itertuples()}


if __name__ == "__main__":
    sys.exit(main())
