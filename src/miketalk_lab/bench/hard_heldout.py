"""Held-out: the model from plain s1 clips against the model from their hard versions.

``python -m miketalk_lab.bench.hard_heldout --pool DIR --out OUT [--train N] [--test M]
[--full] [--cross] [--compare-conversion C]`` takes N training and M test clips of GRID's
s1 (by default the training and held-out clips of ``.bench/config.yaml``'s face s1, in its
order; beyond them, the pool's other clips in name order; with ``--draw K``, the same test
clips and N of the pool's others drawn with seed K: :mod:`miketalk_lab.bench.hard_draws`
measures several draws), and

1. makes each clip's *hard* version (:func:`miketalk_lab.hard_s1.make_hard_clip`: s1 keyed
   onto a textured room, moved by a known smooth similarity, 1280x720; the training
   clips losslessly, the test clips at x264 crf 18, so that both are compressed once as the
   plain clips are);
2. joins the plain training clips and, apart, their hard versions, each into one video
   (:func:`miketalk_lab.bench.joined.join_clips`, x264 crf 18) and builds a model from
   each with ``miketalk build`` and its default ``--frame crop`` (with ``--full``, also
   the plain video with ``--frame full``, the path in the video's own pixels);
3. measures each model on the held-out clips with the lab's held-out evaluation
   (:func:`miketalk_lab.evaluation.heldout.prepare_heldout`, ``evaluate_clip``): the
   model built from plain clips on the plain test clips, the one built from hard clips on
   the hard test clips (with ``--cross``, also each on the other kind). The only change
   to the workflow's held-out evaluation (:func:`heldout_of`): its models, table and
   strip; as there, a crop model's test clips are read as its corpus's were, tracked and
   cropped (:func:`miketalk.corpus.clips.corpus_decoder`), then registered to its
   corpus's reference (its stabilizer), so that the rendered frames (crop pixels) and the
   real ones are compared in the same crop pixels: opening r, mouth LMD (dlib's 68
   points), PSNR and eigenlips all in the 256-pixel crop;
4. pairs the two models clip by clip (:func:`paired`): means, standard deviations, the
   paired difference's mean with its 95 % t interval, against the issue's target
   (|difference of lip-opening r| <= 0.03, |difference of mouth LMD| <= 0.1 px).

With ``--compare-conversion accurate`` (or ``fast``), each crop model is also built with
that ``miketalk build --crop-conversion`` (its crops' colour conversion) and measured on the
same test clips, paired clip by clip with the default's.

Writes ``OUT/clips.tsv`` (every clip, model, test kind and renderer), ``OUT/paired.tsv``,
``OUT/summary.md`` and ``OUT/strip.png`` (a hard test clip's crops above the hard model's
render of it, then the plain clip's crops above the plain model's), and prints the summary.
The clips, joined videos, models and corpora stay under ``OUT/work`` and are reused when
there (delete it to start again).
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import shutil
import subprocess
import sys
import time
import zlib
from collections.abc import Sequence

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.bench.train_test import draw_training, split_clips
from miketalk_lab.evaluation.paired import paired, target_verdict

ROOT = pathlib.Path(__file__).resolve().parents[3]

#: The issue's target: the hard model's lip-opening r within this of the plain model's...
TARGET_R = 0.03
#: ...and its mouth LMD (crop pixels) within this.
TARGET_LMD_PX = 0.1

#: The renderers measured and reported: the paper's morph, the learned coarticulation
#: (``say``'s for typed text), the trained face (from the phones; hearing the recording).
REPORTED_RENDERERS = ("morph", "learned", "trained", "trained_heard")

#: The measures paired: the issue's two first, then the rest of the held-out table's.
PAIRED_MEASURES = ("lip_opening_corr_speech", "mouth_lmd", "lip_opening_amplitude_speech",
                   "mouth_lmd_speech", "opening_corr_speech", "psnr_mouth")  # fmt: skip

#: Each measure's target on the paired difference's mean (absolute), where the issue sets one.
TARGETS = {"lip_opening_corr_speech": TARGET_R, "mouth_lmd": TARGET_LMD_PX}


def pair_models(table: pd.DataFrame, a: tuple[str, str], b: tuple[str, str], *,
                renderers: Sequence[str] = REPORTED_RENDERERS,
                measures: Sequence[str] = PAIRED_MEASURES) -> pd.DataFrame:  # fmt: skip
    """Model ``b`` against model ``a`` clip by clip: one row per renderer and measure with
    :func:`paired`'s figures and, where the issue sets one, the ``target`` and ``verdict``.
    ``table`` has ``clip``, ``model``, ``test``, ``renderer`` and the measures; ``a`` and
    ``b`` are ``(model, test)`` pairs."""
    rows = []
    for renderer in renderers:
        pa, pb = (
            table[
                (table["model"] == m) & (table["test"] == t) & (table["renderer"] == renderer)
            ].set_index("clip")
            for m, t in (a, b)
        )
        for measure in (x for x in measures if x in pa and x in pb and len(pa) and len(pb)):
            row = {"renderer": renderer, "measure": measure} | paired(pa[measure], pb[measure])
            limit = TARGETS.get(measure)
            row["target"] = math.nan if limit is None else limit
            row["verdict"] = "" if limit is None else target_verdict(
                row["diff_mean"], row["diff_low"], row["diff_high"], limit
            )  # fmt: skip
            rows.append(row)
    return pd.DataFrame(rows)


def heldout_of(model_dir: pathlib.Path, corpus_dir: pathlib.Path, clips: Sequence, *,
               name: str, keep: str | None = None) -> tuple[pd.DataFrame, dict]:  # fmt: skip
    """A model's held-out measures on ``clips`` in its corpus's frame: the workflow's held-out
    evaluation (:func:`~miketalk_lab.evaluation.heldout.heldout_stage`), a test clip read as
    the corpus's clips were (:func:`~miketalk.corpus.clips.corpus_decoder`), with one model
    and a clip that fails left out.

    Returns the per clip and renderer summaries (``clip``, ``renderer``, ``model``, the
    measures; a clip that fails is left out) and ``{"skipped": [(clip, why)], "real":
    frames, "morph": frames}``, the frames those of the clip ``keep`` (for the strip).
    """
    from miketalk.corpus.clip_sources import ClipError
    from miketalk.corpus.clips import corpus_decoder, corpus_stabilizer
    from miketalk.corpus.eigenlips import read_eigenlips
    from miketalk.model.face import Model
    from miketalk.mouth import mouth_region
    from miketalk.visemes import VisemeTable
    from miketalk_lab.evaluation.heldout import evaluate_clip, prepare_heldout
    from miketalk_lab.evaluation.landmarks import face_landmarks

    decode = corpus_decoder(corpus_dir)
    stabilizer = corpus_stabilizer(corpus_dir)
    box = mouth_region(corpus_dir)
    eigenlips = read_eigenlips(corpus_dir / "eigenlips.npz").eigenlips
    models = {name: Model(model_dir)}
    table = VisemeTable(grouping={})
    landmarks = face_landmarks()
    rows: list[dict] = []
    kept: dict = {"skipped": []}
    for clip in clips:
        try:
            heldout = prepare_heldout(clip, stabilizer=stabilizer, table=table, decode=decode)
            summaries, _, renders = evaluate_clip(
                heldout, models, mouth_box=box, eigenlips=eigenlips, baselines_of=name,
                landmarks=landmarks,
            )  # fmt: skip
        except (ClipError, MiketalkError) as err:
            kept["skipped"].append((clip.id, str(err)))
            print(f"  {name}: clip {clip.id} left out: {err}", file=sys.stderr, flush=True)
            continue
        rows += summaries
        if clip.id == keep:
            kept["real"], kept["morph"] = heldout.real, renders[f"morph:{name}"]
    return pd.DataFrame(rows), kept


def strip_image(rows: Sequence[np.ndarray], *, columns: int = 8) -> np.ndarray:
    """Rows of frames (each ``(N, h, w, 3)``, the same ``N``) as one image: ``columns``
    frames of each row, evenly spaced over the clip, a 2-pixel white line between rows."""
    n = min(len(r) for r in rows)
    picks = np.linspace(0, n - 1, columns).round().astype(int)
    lines = []
    for frames in rows:
        lines.append(np.concatenate([frames[k] for k in picks], axis=1))
        lines.append(np.full((2, lines[-1].shape[1], 3), 255, np.uint8))
    return np.concatenate(lines[:-1], axis=0)


def main(argv: Sequence[str] | None = None) -> int:
    """Make, join, build and measure; see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="(unused: see --train and --test)")
    parser.add_argument("--pool", type=pathlib.Path, required=True, help="GRID s1's folder")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="folder for the results")
    parser.add_argument("--train", type=int, default=40, help="training clips (default 40)")
    parser.add_argument("--test", type=int, default=20, help="held-out clips (default 20)")
    parser.add_argument("--config", type=pathlib.Path, default=ROOT / ".bench" / "config.yaml")
    parser.add_argument("--seed", type=int, default=0, help="the room's and motions' seed")
    parser.add_argument("--draw", type=int, default=0, help="training draw: 0 the config's "
                        "clips, K > 0 the pool's others shuffled with seed K")  # fmt: skip
    parser.add_argument("--full", action="store_true", help="also build plain with --frame full")
    parser.add_argument("--cross", action="store_true", help="also each model on the other kind")
    parser.add_argument("--workers", type=int, default=None, help="miketalk build --workers")
    parser.add_argument(
        "--compare-conversion", choices=("auto", "fast", "accurate"), default=None,
        help="also build each crop model with this --crop-conversion and pair it, clip by "
        "clip, with the default's on the same test clips",
    )  # fmt: skip

    def check(args: argparse.Namespace) -> str | None:
        if args.train < 2 or args.test < 2:
            return "--train and --test must be at least 2"
        if args.draw < 0:
            return "--draw must be 0 or more"
        return None

    return run_bench(parser, argv, _run, check=check)


def _orders(config: pathlib.Path) -> tuple[list[str], list[str]]:
    """Face s1's training and test clips in a workflow config (none when it has no s1)."""
    import yaml

    if not config.is_file():
        return [], []
    corpus = (yaml.safe_load(config.read_text()).get("faces", {}).get("s1") or {}).get("corpus")
    corpus = corpus or {}
    return list(corpus.get("train", [])), list(corpus.get("test", []))


def _make_hard(ids: Sequence[str], pool: pathlib.Path, folder: pathlib.Path, *, seed: int,
               crf: int) -> None:  # fmt: skip
    """Each clip's hard version ``folder/<id>.mp4`` (and its truth, ``<id>.npy``), unless there."""
    from miketalk_lab.hard_s1 import make_hard_clip

    folder.mkdir(parents=True, exist_ok=True)
    for clip in ids:
        path = folder / f"{clip}.mp4"
        if path.is_file() and (folder / f"{clip}.npy").is_file():
            continue
        hard = make_hard_clip(pool / "video" / f"{clip}.mpg", folder / f"{clip}.part.mp4",
                              seed=seed, crf=crf)  # fmt: skip
        np.save(folder / f"{clip}.npy", hard.truth)
        (folder / f"{clip}.part.mp4").rename(path)


def _build(video: pathlib.Path, transcript: pathlib.Path, model: pathlib.Path,
           corpus: pathlib.Path, *, frame: str, workers: int | None,
           conversion: str | None = None) -> dict:  # fmt: skip
    """``miketalk build --frame FRAME [--crop-conversion CONVERSION]``, its corpus kept; its
    JSON (reused when there)."""
    record = model.parent / f"{model.name}.build.json"
    if record.is_file() and model.is_dir() and corpus.is_dir():
        return json.loads(record.read_text())
    shutil.rmtree(corpus, ignore_errors=True)
    command = [
        str(pathlib.Path(sys.executable).parent / "miketalk"), "build", str(video),
        "--transcript", str(transcript), "-o", str(model), "--force", "--json",
        "--frame", frame, "--keep-corpus", str(corpus),
    ]  # fmt: skip
    if workers is not None:
        command += ["--workers", str(workers)]
    if conversion is not None:
        command += ["--crop-conversion", conversion]
    started = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True)
    if proc.returncode != 0:
        lines = proc.stderr.strip().splitlines() or ["(no message)"]
        (model.parent / f"{model.name}.build.err").write_text(proc.stderr, "utf-8")
        raise MiketalkError(f"miketalk build --frame {frame} {video}: {lines[-1]}")
    result = json.loads(proc.stdout) | {"wall_seconds": time.perf_counter() - started}
    record.write_text(json.dumps(result, indent=1) + "\n", "utf-8")
    return result


def _run(args: argparse.Namespace) -> str:
    from miketalk.corpus.clip_sources import clip_sources
    from miketalk.media.images import write_png
    from miketalk_lab.bench.joined import join_clips

    pool, out = args.pool, args.out
    work = out / "work"
    work.mkdir(parents=True, exist_ok=True)
    pool_ids = [p.stem for p in (pool / "video").glob("*.mpg")]
    train, test = split_clips(pool_ids, *_orders(args.config), args.train, args.test)
    if args.draw:
        train = draw_training(pool_ids, test, args.train, args.draw)
    (out / "clips.json").write_text(json.dumps({"train": train, "test": test}, indent=1) + "\n")
    seconds: dict[str, float] = {}
    tag = f"{len(train)}-{zlib.crc32(','.join(train).encode()):08x}"  # this training set's

    started = time.perf_counter()
    _make_hard(train, pool, work / "hard_train", seed=args.seed, crf=0)
    _make_hard(test, pool, work / "hard_test", seed=args.seed, crf=18)
    seconds["hard clips"] = time.perf_counter() - started
    transcripts, timings = pool / "transcripts.txt", str(pool / "align" / "{id}.align")
    media = {"plain": str(pool / "video" / "{id}.mpg"),
             "hard": str(work / "hard_train" / "{id}.mp4")}  # fmt: skip
    joined = {}
    for kind in ("plain", "hard"):
        started = time.perf_counter()
        folder = work / f"joined_{kind}_{tag}"
        if not (folder / "joined.mp4").is_file():
            join_clips(train, folder, media=media[kind], transcripts=transcripts,
                       timings=timings, crf=18)  # fmt: skip
        joined[kind] = folder
        seconds[f"join {kind}"] = time.perf_counter() - started

    builds = [("plain", "plain", "crop", None), ("hard", "hard", "crop", None)]
    if args.full:
        builds.append(("full", "plain", "full", None))
    other = args.compare_conversion  # the same crop models, read with another conversion
    if other:
        builds += [(f"{kind}-{other}", kind, "crop", other) for kind in ("plain", "hard")]
    results = {}
    for name, kind, frame, conversion in builds:
        print(f"building {name} (--frame {frame}) ...", file=sys.stderr, flush=True)
        results[name] = _build(
            joined[kind] / "joined.mp4", joined[kind] / "transcript.txt",
            work / f"model_{name}_{tag}", work / f"corpus_{name}_{tag}", frame=frame,
            workers=args.workers, conversion=conversion,
        )  # fmt: skip

    test_clips = {
        "plain": clip_sources(test, media=str(pool / "video" / "{id}.mpg"),
                              transcripts=transcripts, timings=timings),
        "hard": clip_sources(test, media=str(work / "hard_test" / "{id}.mp4"),
                             transcripts=transcripts, timings=timings),
    }  # fmt: skip
    runs = [("plain", "plain"), ("hard", "hard")]
    if args.cross:
        runs += [("plain", "hard"), ("hard", "plain")]
    if args.full:
        runs.append(("full", "plain"))
    if other:
        runs += [(f"{kind}-{other}", kind) for kind in ("plain", "hard")]
    keep = test[0]
    tables, strips, skipped = [], {}, []
    for model, kind in runs:
        print(f"held out: model {model} on {kind} test clips ...", file=sys.stderr, flush=True)
        started = time.perf_counter()
        part, kept = heldout_of(work / f"model_{model}_{tag}", work / f"corpus_{model}_{tag}",
                                test_clips[kind], name=model, keep=keep)  # fmt: skip
        seconds[f"held out {model} on {kind}"] = time.perf_counter() - started
        tables.append(part.assign(test=kind))
        skipped += [(model, kind, c, why) for c, why in kept["skipped"]]
        if "real" in kept:
            strips[(model, kind)] = kept
    table = pd.concat(tables, ignore_index=True)
    front = ["clip", "model", "test", "renderer"]
    table = table[front + [c for c in table.columns if c not in front]]
    table.to_csv(out / "clips.tsv", sep="\t", index=False, float_format="%.5f")

    comparisons = [("hard model on hard clips vs plain model on plain clips",
                    ("plain", "plain"), ("hard", "hard"))]  # fmt: skip
    if args.cross:
        comparisons += [
            ("plain model: hard clips vs plain clips (the test crops alone)",
             ("plain", "plain"), ("plain", "hard")),
            ("hard model vs plain model, both on plain clips (the models alone)",
             ("plain", "plain"), ("hard", "plain")),
        ]  # fmt: skip
    if other:
        comparisons += [
            (f"{kind} model read with the {other} conversion vs the default's, on {kind} clips",
             (kind, kind), (f"{kind}-{other}", kind))
            for kind in ("plain", "hard")
        ]  # fmt: skip
    pairs = []
    for title, a, b in comparisons:
        pairs.append(pair_models(table, a, b).assign(comparison=title))
    pairs = pd.concat(pairs, ignore_index=True)
    pairs.to_csv(out / "paired.tsv", sep="\t", index=False, float_format="%.5f")

    rows = []
    if ("hard", "hard") in strips:
        source = work / "hard_test" / f"{keep}.mp4"
        rows += [_thumbs(source, len(strips[("hard", "hard")]["real"])),
                 strips[("hard", "hard")]["real"], strips[("hard", "hard")]["morph"]]  # fmt: skip
    if ("plain", "plain") in strips:
        rows += [strips[("plain", "plain")]["real"], strips[("plain", "plain")]["morph"]]
    if rows:
        write_png(out / "strip.png", strip_image(rows))

    summary = _summary(args, train, test, results, seconds, table, pairs, skipped, keep)
    (out / "summary.md").write_text(summary, "utf-8")
    return summary


def _thumbs(video: pathlib.Path, count: int) -> np.ndarray:
    """The hard clip's whole frames, 256 px wide (the strip's first row; letterboxed to the
    crops' square)."""
    import cv2

    from miketalk.media.decode import read_video

    frames, _ = read_video(video, frames=count)
    out = np.zeros((len(frames), 256, 256, 3), np.uint8)
    for k, frame in enumerate(frames):
        small = cv2.resize(frame, (256, 144), interpolation=cv2.INTER_AREA)
        out[k, 56:200] = small
    return out


def _summary(args, train, test, results, seconds, table, pairs, skipped, keep) -> str:
    """The markdown summary."""
    lines = [
        "# Held-out: plain s1 vs hard s1",
        "",
        f"{len(train)} training clips (draw {args.draw}; first: {', '.join(train[:3])}, ...), "
        f"{len(test)} "
        f"held-out clips ({', '.join(test)}); hard: seed {args.seed}, 1280x720.",
        "",
        "Builds: "
        + "; ".join(
            f"{name}: {r.get('wall_seconds', float('nan')):.0f} s, "
            f"{r.get('utterances', '?')} utterances"
            for name, r in results.items()
        )
        + ".",
        "Times: " + ", ".join(f"{k} {v:.0f} s" for k, v in seconds.items()) + ".",
        "",
    ]
    if skipped:
        lines += ["Left out of the held-out measures:", ""]
        lines += [f"- model {m} on {k}: {c}: {why}" for m, k, c, why in skipped]
        lines += [""]
    for title, part in pairs.groupby("comparison", sort=False):
        lines += [f"## {title}", "", _pairs_markdown(part), ""]
    lines += [f"Strip (`strip.png`): clip {keep}.", ""]
    return "\n".join(lines)


def _pairs_markdown(part: pd.DataFrame) -> str:
    """One comparison's rows as a markdown table."""
    head = (
        "| renderer | measure | clips | A mean (sd) | B mean (sd) | B - A mean (sd) | 95 % "
        "interval | target | verdict |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    )
    body = []
    for r in part.itertuples():
        target = "" if not np.isfinite(r.target) else f"{r.target:g}"
        body.append(
            f"| {r.renderer} | {r.measure} | {r.clips} | {r.a_mean:.3f} ({r.a_sd:.3f}) | "
            f"{r.b_mean:.3f} ({r.b_sd:.3f}) | {r.diff_mean:+.3f} ({r.diff_sd:.3f}) | "
            f"[{r.diff_low:+.3f}, {r.diff_high:+.3f}] | {target} | {r.verdict} |"
        )
    return "\n".join([head, *body])


if __name__ == "__main__":
    sys.exit(main())
