"""How much of the source's fine detail a dub keeps where it draws the mouth.

``python -m miketalk_lab.bench.dub_detail --source VIDEO --dub NAME=MP4 [--dub ...]
[--frames N] [--out OUT]`` reads the source video and each dub of it frame by frame in step
(one frame of each at a time; a dub longer than its source loops it, so only the source's
first ``--frames`` frames, all by default, are compared). In each frame the region any dub
changed (more than :data:`CHANGED` grey levels in some channel, opened by a 5x5 square, at
least :data:`MIN_PIXELS` pixels) is boxed, the same box for every dub, and two ratios of
the dub's grey box to the source's are taken: the variance of its Laplacian (the finest
detail: pores, lip lines) and its gradient energy (edges). 1 keeps the source's detail, less
is softer. Different speech has different mouth shapes, so the figure is a comparison of
dubs of one source (crop sizes, lip-sync models), not an absolute measure of blur. Prints
each dub's median with its 10th and 90th percentiles and, for each dub against the first,
the paired mean difference with a 95 % bootstrap interval; writes ``OUT/dub_detail.tsv``
(one row a frame) and ``OUT/dub_detail.md``.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator, Sequence
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk_lab.bench.command import bench_parser, run_bench

#: Grey levels by which a dub's pixel must differ from the source's to count as drawn.
CHANGED = 12
#: The fewest changed pixels that make a frame's region.
MIN_PIXELS = 500
#: The measures, by column name.
MEASURES = ("laplacian", "gradient")


def main(argv: Sequence[str] | None = None) -> int:
    """Measure the dubs; see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="unused")
    parser.add_argument("--source", type=Path, required=True, help="the dubbed video")
    parser.add_argument("--dub", action="append", required=True, metavar="NAME=MP4",
                        help="a dub of it, named (give two or more to compare)")  # fmt: skip
    parser.add_argument("--frames", type=int, default=None, help="the source's first N frames")
    parser.add_argument("--out", type=Path, default=Path("results/bench/dub_detail"))
    return run_bench(parser, argv, _run, check=_check)


def _check(args: argparse.Namespace) -> str | None:
    if any("=" not in d for d in args.dub):
        return "--dub takes NAME=MP4"
    if args.frames is not None and args.frames < 1:
        return "--frames must be at least 1"
    return None


def _run(args: argparse.Namespace) -> str:
    dubs = dict(d.split("=", 1) for d in args.dub)
    table = measure(args.source, {k: Path(v) for k, v in dubs.items()}, frames=args.frames)
    text = summary(table)
    args.out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(args.out / "dub_detail.tsv", table.to_csv(sep="\t", index=False))
    write_text_atomic(args.out / "dub_detail.md", text + "\n")
    return text


def _frames(path: Path) -> Iterator[np.ndarray]:
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        raise MiketalkError(f"cannot read {path}")
    try:
        while True:
            ok, frame = capture.read()
            if not ok:
                return
            yield frame
    finally:
        capture.release()


def _laplacian(grey: np.ndarray) -> float:
    return float(cv2.Laplacian(grey, cv2.CV_32F, ksize=3).var())


def _gradient(grey: np.ndarray) -> float:
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1)
    return float(np.mean(gx * gx + gy * gy))


def changed_box(source: np.ndarray, dubs: Sequence[np.ndarray]) -> tuple[slice, slice] | None:
    """The box around the pixels any of ``dubs`` changed in ``source`` (None: too few).

    Parameters
    ----------
    source : numpy.ndarray
        ``(H, W, 3)`` uint8.
    dubs : sequence of numpy.ndarray
        Frames of the same size.

    Returns
    -------
    tuple of slice or None
        Rows and columns.
    """
    drawn = np.zeros(source.shape[:2], np.uint8)
    kernel = np.ones((5, 5), np.uint8)
    for dub in dubs:
        diff = cv2.absdiff(source, dub).max(axis=2) > CHANGED
        drawn |= cv2.morphologyEx(diff.astype(np.uint8), cv2.MORPH_OPEN, kernel)
    rows, cols = np.nonzero(drawn)
    if len(rows) < MIN_PIXELS:
        return None
    return slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1)


def measure(source: Path, dubs: dict[str, Path], *, frames: int | None = None) -> pd.DataFrame:
    """Each compared frame's box and each dub's two ratios to the source (module docstring).

    Raises
    ------
    MiketalkError
        A video that cannot be read, dubs of another size, or no frame with a drawn region.
    """
    streams = [_frames(source)] + [_frames(p) for p in dubs.values()]
    rows = []
    for index, (src, *drawn) in enumerate(zip(*streams, strict=False)):
        if frames is not None and index >= frames:
            break
        if any(d.shape != src.shape for d in drawn):
            raise MiketalkError("the dubs are not the source's size")
        box = changed_box(src, drawn)
        if box is None:
            continue
        grey = [cv2.cvtColor(f[box], cv2.COLOR_BGR2GRAY).astype(np.float32) for f in (src, *drawn)]
        row = {"frame": index, "width": box[1].stop - box[1].start,
               "height": box[0].stop - box[0].start}  # fmt: skip
        for name, g in zip(dubs, grey[1:], strict=True):
            row[f"{name}_laplacian"] = _laplacian(g) / max(_laplacian(grey[0]), 1e-9)
            row[f"{name}_gradient"] = _gradient(g) / max(_gradient(grey[0]), 1e-9)
        rows.append(row)
    if not rows:
        raise MiketalkError("no frame of the dubs differs from the source")
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame, *, resamples: int = 2000) -> str:
    """The Markdown table of each dub's ratios and each dub's paired difference to the first."""
    names = [c[: -len("_laplacian")] for c in table.columns if c.endswith("_laplacian")]
    lines = [
        f"{len(table)} frames, box median {table.width.median():.0f} x "
        f"{table.height.median():.0f} px",
        "",
        "| dub | Laplacian variance ratio, median [p10, p90] | gradient energy ratio |"
        f" paired vs {names[0]} (Laplacian; gradient), mean [95 % CI] |",
        "|---|---|---|---|",
    ]
    rng = np.random.default_rng(0)
    picks = rng.integers(0, len(table), (resamples, len(table)))
    for name in names:
        cells = []
        for measure_name in MEASURES:
            v = table[f"{name}_{measure_name}"].to_numpy()
            cells.append(f"{np.median(v):.3f} [{np.percentile(v, 10):.3f}, "
                         f"{np.percentile(v, 90):.3f}]")  # fmt: skip
        paired = []
        for measure_name in MEASURES:
            d = (table[f"{name}_{measure_name}"] - table[f"{names[0]}_{measure_name}"]).to_numpy()
            means = d[picks].mean(axis=1)
            paired.append(f"{d.mean():+.3f} [{np.percentile(means, 2.5):+.3f}, "
                          f"{np.percentile(means, 97.5):+.3f}]")  # fmt: skip
        lines.append(f"| {name} | {cells[0]} | {cells[1]} | {'; '.join(paired)} |")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
