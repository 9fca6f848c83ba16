"""Benchmark: in-between frames of real video by morph, dissolve and SloMo-style warps.

``python -m miketalk_lab.bench.inbetween --clips DIR [--out OUT] [--limit N]`` reads
every clip of ``DIR`` (``*.mpg``, ``*.mp4``, ``*.avi``, ``*.mov``), finds its
mouth box, predicts frame ``t + k/2`` from frames ``t`` and ``t + k`` by every
method of :mod:`miketalk_lab.evaluation.inbetween` and measures each prediction
against the real frame on the mouth region.

The estimators default to the model's flow method (``default``: the
configuration's ``flow.method``, with its settings, for ``--face`` if the
face names its own) and OpenCV's DIS (medium) and Farneback. An estimator is
given as ``name`` or ``name:setting=value,setting=value`` (values read as
YAML: ``bergen:window=8.0``).

Writes ``OUT/inbetween.csv`` (one row per clip, t, k and method),
``OUT/inbetween_summary.csv`` (per k and method: mean and sd over clips, gain
over the dissolve), ``OUT/boxes.csv`` (each clip's mouth box) and
``OUT/inbetween.md`` (the command, the settings, the timing and the tables),
and prints the markdown.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.flow.registry import Estimator, get_estimator
from miketalk.media.atomic import write_text_atomic
from miketalk.mouth.lip_colour import find_mouth_box
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.evaluation.inbetween import VARIANTS, Method, default_methods, inbetween_table
from miketalk_lab.evaluation.inbetween_summary import summarize_inbetween, summary_markdown

#: File name endings read as clips.
SUFFIXES = (".mpg", ".mp4", ".avi", ".mov")

_DEFAULT_ESTIMATORS = ("default", "dis_medium", "farneback")
_DEFAULT_VARIANTS = ("morph", "morph-nomedian", "morph-bilinear", "slomo")


def list_clips(
    directory: Path, *, limit: int | None = None, exclude: Path | None = None
) -> list[Path]:
    """The clips of ``directory`` in name order; ``limit`` of them evenly spread over it.

    Clips whose name (stem) is also a clip's in ``exclude`` are left out first
    (to measure on clips a model was not built from).

    Raises
    ------
    MiketalkError
        If a folder does not exist, or no clip is left.
    """
    if not directory.is_dir():
        raise MiketalkError(f"--clips {directory} is not a folder")
    paths = sorted(p for p in directory.iterdir() if p.suffix.lower() in SUFFIXES)
    if exclude is not None:
        if not exclude.is_dir():
            raise MiketalkError(f"--exclude {exclude} is not a folder")
        names = {p.stem for p in exclude.iterdir() if p.suffix.lower() in SUFFIXES}
        paths = [p for p in paths if p.stem not in names]
    if not paths:
        raise MiketalkError(f"no clip ({', '.join(SUFFIXES)}) in {directory}")
    if limit is not None and limit < len(paths):
        picks = np.unique(np.round(np.linspace(0, len(paths) - 1, limit)).astype(int))
        paths = [paths[i] for i in picks]
    return paths


def model_estimator(config: Path, face: str | None = None) -> tuple[str, Estimator]:
    """The model's flow method in a workflow configuration: its name and its estimator.

    ``faces.<face>.flow.method`` if the face names one, else ``flow.method``;
    the estimator and settings are that key of ``flow.methods``.

    Raises
    ------
    MiketalkError
        If the file cannot be read or does not name a method.
    """
    try:
        document = yaml.safe_load(config.read_text("utf-8")) or {}
    except (OSError, yaml.YAMLError) as err:
        raise MiketalkError(f"cannot read the configuration {config}: {err}") from err
    flow = document.get("flow") or {}
    method = flow.get("method", "bergen")
    if face is not None:
        method = (
            ((document.get("faces") or {}).get(face) or {}).get("flow", {}).get("method", method)
        )
    entry = (flow.get("methods") or {}).get(method)
    if entry is None:
        return method, get_estimator(method)
    return method, get_estimator(entry["estimator"], **(entry.get("settings") or {}))


def parse_estimator(spec: str) -> tuple[str, Estimator]:
    """``name`` or ``name:setting=value,...`` as a (label, estimator) pair; the label is ``spec``.

    Raises
    ------
    MiketalkError
        For an unknown estimator or setting, or a setting without ``=``.
    """
    name, _, rest = spec.partition(":")
    settings: dict[str, Any] = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        if not eq:
            raise MiketalkError(f"estimator {spec!r}: {item!r} is not setting=value")
        settings[key.strip()] = yaml.safe_load(value)
    return spec, get_estimator(name, **settings)


def _describe(estimator: Estimator) -> str:
    """``name(setting=value, ...)`` without the settings left to the library (None)."""
    bound = ", ".join(f"{k}={v!r}" for k, v in estimator.settings.items() if v is not None)
    return f"{estimator.name}({bound})"


def _parse_box(text: str) -> tuple[int, int, int, int]:
    try:
        x, y, w, h = (int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not x,y,w,h") from None
    return x, y, w, h


def _measure_clip(
    path: Path,
    methods: list[Method],
    ks: list[int],
    step: int,
    context: float | None,
    mouth: str,
    box: tuple[int, int, int, int] | None,
) -> tuple[pd.DataFrame, tuple[int, int, int, int], dict[str, float]]:
    """Decode one clip, find its mouth box, measure it (runs in a worker process)."""
    from miketalk.media.decode import read_video

    t0 = time.perf_counter()
    frames, _fps = read_video(path)
    t1 = time.perf_counter()
    if box is None:
        if mouth == "locate":
            from miketalk.stabilize import locate_face, locate_mouth

            box = locate_mouth(frames, locate_face(frames[len(frames) // 2]))
        else:
            box = find_mouth_box(frames)
    t2 = time.perf_counter()
    table = inbetween_table(
        frames, mouth_box=box, ks=ks, methods=methods, step=step, context=context, clip=path.stem
    )
    t3 = time.perf_counter()
    box = tuple(int(v) for v in box)
    return table, box, {"decode": t1 - t0, "box": t2 - t1, "measure": t3 - t2}


def main(argv: Sequence[str] | None = None) -> int:
    """Measure in-between frames of a folder of clips.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (``sys.argv[1:]`` by default).

    Returns
    -------
    int
        0 on success, 1 on a MiketalkError (printed on stderr).
    """
    parser = bench_parser(__name__, __doc__, limit_help="N clips evenly spread over the folder's")
    parser.add_argument("--clips", type=Path, required=True, help="a folder of video clips")
    parser.add_argument(
        "--out",
        type=Path,
        default=defaults.RESULTS / "bench" / "inbetween",
        help="folder for the tables (default: %(default)s)",
    )
    parser.add_argument(
        "--exclude", type=Path, default=None, help="leave out clips named as clips of this folder"
    )
    parser.add_argument(
        "--ks", type=int, nargs="+", default=[2, 4, 8], help="gaps k (even; default: 2 4 8)"
    )
    parser.add_argument("--step", type=int, default=2, help="every step-th t (default: 2)")
    parser.add_argument(
        "--estimators",
        nargs="+",
        default=list(_DEFAULT_ESTIMATORS),
        help="name or name:setting=value,...; default = the model's (default: %(default)s)",
    )
    parser.add_argument(
        "--variants",
        nargs="+",
        default=list(_DEFAULT_VARIANTS),
        choices=list(VARIANTS),
        help="methods per estimator (default: %(default)s)",
    )
    parser.add_argument(
        "--config", type=Path, default=Path("config.yaml"), help="for default (%(default)s)"
    )
    parser.add_argument("--face", default=None, help="the face whose flow method is default")
    parser.add_argument(
        "--context",
        type=float,
        default=1.0,
        help="flows on the mouth box grown by this times its size per side; <0: whole frame",
    )
    parser.add_argument(
        "--mouth",
        choices=["lips", "locate"],
        default="lips",
        help="mouth box: find_mouth_box (lips) or corpus.stabilize.locate_mouth",
    )
    parser.add_argument("--mouth-box", type=_parse_box, default=None, help="x,y,w,h for every clip")
    parser.add_argument("--workers", type=int, default=1, help="processes (default: 1)")
    return run_bench(
        parser,
        argv,
        lambda args: _run(args, argv),
        check=lambda args: (
            "--workers and --step must be at least 1" if args.workers < 1 or args.step < 1 else None
        ),
    )


def _run(args: argparse.Namespace, argv: Sequence[str] | None) -> str:
    """Measure the clips, write the tables and the summary; return the summary."""
    context = None if args.context < 0 else args.context
    start = time.perf_counter()
    clips = list_clips(args.clips, limit=args.limit, exclude=args.exclude)
    estimators: list[tuple[str, Estimator]] = []
    for spec in args.estimators:
        if spec == "default":
            estimators.append(model_estimator(args.config, args.face))
        else:
            estimators.append(parse_estimator(spec))
    methods = default_methods(estimators, variants=args.variants)
    jobs = [(p, methods, args.ks, args.step, context, args.mouth, args.mouth_box) for p in clips]
    if args.workers == 1:
        results = [_measure_clip(*job) for job in jobs]
    else:
        with ProcessPoolExecutor(args.workers) as pool:
            results = list(pool.map(_measure_clip, *zip(*jobs, strict=True)))
    seconds = time.perf_counter() - start
    table = pd.concat([r[0] for r in results], ignore_index=True)
    summary = summarize_inbetween(table)
    boxes = pd.DataFrame(
        [(p.stem, *r[1]) for p, r in zip(clips, results, strict=True)],
        columns=["clip", "x", "y", "w", "h"],
    )
    parts = {key: sum(r[2][key] for r in results) for key in ("decode", "box", "measure")}
    settings = "; ".join(f"{label} = {_describe(e)}" for label, e in estimators)
    command = "python -m miketalk_lab.bench.inbetween " + shlex.join(
        sys.argv[1:] if argv is None else list(argv)
    )
    w, h = boxes["w"].median(), boxes["h"].median()
    left_out = f" (none of {args.exclude})" if args.exclude else ""
    ks = ", ".join(map(str, args.ks))
    crop = "the whole frame" if context is None else f"the box grown by {context} of its size"
    lines = [
        "# In-between frames of real video",
        "",
        f"`{command}`",
        "",
        f"{len(clips)} clips of {args.clips}{left_out}; k = {ks}; t = 0, {args.step}, "
        f"{2 * args.step}, ...; mouth box: {args.mouth_box or args.mouth} (median "
        f"{w:.0f}x{h:.0f} px); flows on {crop} per side. Estimators: {settings}.",
        "",
        f"{seconds:.1f} s with {args.workers} worker(s) (decoding {parts['decode']:.1f} s, "
        f"mouth boxes {parts['box']:.1f} s, measuring {parts['measure']:.1f} s, summed over "
        "clips).",
        "",
        summary_markdown(summary),
    ]
    markdown = "\n".join(lines)
    args.out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(args.out / "inbetween.csv", table.to_csv(index=False))
    write_text_atomic(args.out / "inbetween_summary.csv", summary.to_csv(index=False))
    write_text_atomic(args.out / "boxes.csv", boxes.to_csv(index=False))
    write_text_atomic(args.out / "inbetween.md", markdown)
    return markdown


if __name__ == "__main__":
    sys.exit(main())
