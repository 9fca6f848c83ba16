"""Benchmark of the forced aligner against GRID's word timings.

``python -m miketalk_lab.bench.aligner --pool DIR --out OUT [--limit N]`` aligns
every clip of a GRID-style pool (``video/<id>.mpg``, ``align/<id>.align``,
``transcripts.txt``) from its transcript alone, *without* GRID's word timings,
and compares each word's start and end with GRID's ``.align``.

Every word boundary counts, the ones against silence too (a clip's first
word's start, its last word's end, and either side of a pause): they are where
GRID's own alignment is least sure, and leaving them out would flatter the
aligner. The table splits the figures by the kind of boundary as well.

Writes ``OUT/boundaries.csv`` (one row per word boundary: clip, word, its index,
which boundary, whether the other side is a word or silence, our time, GRID's
time, the signed error in ms) and ``OUT/summary.md`` (median, 90th and 95th
percentile and largest absolute error, clips, seconds per clip), and prints
the summary.
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio
from miketalk.speech.align import align
from miketalk.speech.word_timings import WordTiming, read_word_timings
from miketalk_lab.bench.command import bench_parser, run_bench

#: The issue's target: median and 90th percentile absolute boundary error, ms.
TARGET_MEDIAN_MS = 20.0
TARGET_P90_MS = 50.0

#: Word timings closer than this (s) count as touching: no silence between them.
_TOUCH = 1e-6

_COLUMNS = (
    "clip", "word", "index", "boundary", "against", "ours_s", "grid_s", "error_ms",
)  # fmt: skip


def _pool_clips(pool: Path) -> list[tuple[str, list[str]]]:
    """The clips of a pool with their transcripts, in name order."""
    transcripts = pool / "transcripts.txt"
    try:
        lines = transcripts.read_text("utf-8").splitlines()
    except OSError as err:
        raise MiketalkError(f"cannot read {transcripts}: {err.strerror}") from err
    clips = []
    for line in lines:
        if line.strip():
            clip, *words = line.split()
            clips.append((clip, words))
    if not clips:
        raise MiketalkError(f"{transcripts} lists no clips")
    return sorted(clips)


def _boundaries(
    clip: str, ours: Sequence[WordTiming], grid: Sequence[WordTiming]
) -> list[dict[str, object]]:
    """One row per word start and end."""
    rows = []
    for i, (mine, theirs) in enumerate(zip(ours, grid, strict=True)):
        before = i > 0 and theirs.start - grid[i - 1].end < _TOUCH
        after = i + 1 < len(grid) and grid[i + 1].start - theirs.end < _TOUCH
        for boundary, our_time, grid_time, touching in (
            ("start", mine.start, theirs.start, before),
            ("end", mine.end, theirs.end, after),
        ):
            rows.append(
                {
                    "clip": clip,
                    "word": theirs.word,
                    "index": i,
                    "boundary": boundary,
                    "against": "word" if touching else "silence",
                    "ours_s": round(our_time, 6),
                    "grid_s": round(grid_time, 6),
                    "error_ms": round(1000.0 * (our_time - grid_time), 3),
                }
            )
    return rows


def _figures(errors: np.ndarray) -> dict[str, float]:
    absolute = np.abs(errors)
    return {
        "n": float(absolute.size),
        "median": float(np.median(absolute)),
        "p90": float(np.percentile(absolute, 90)),
        "p95": float(np.percentile(absolute, 95)),
        "max": float(absolute.max()),
        "within_20": float(np.mean(absolute <= 20.0 + 1e-6)),
        "within_50": float(np.mean(absolute <= 50.0 + 1e-6)),
    }


def _summary(rows: list[dict[str, object]], clips: int, seconds: dict[str, float]) -> str:
    errors = np.array([r["error_ms"] for r in rows], dtype=np.float64)
    kinds = np.array([r["against"] for r in rows])
    lines = [
        "# Forced alignment vs GRID's word timings",
        "",
        f"{clips} clips aligned from their transcripts alone (no GRID timings); "
        f"{len(rows)} word boundaries (each word's start and end).",
        "",
        "| boundaries | n | median ms | p90 ms | p95 ms | max ms | <= 20 ms | <= 50 ms |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    groups = [("all", np.ones(len(rows), bool))]
    groups += [(f"against {k}", kinds == k) for k in ("word", "silence")]
    figures = {}
    for name, mask in groups:
        if not mask.any():
            continue
        f = _figures(errors[mask])
        figures[name] = f
        lines.append(
            f"| {name} | {f['n']:.0f} | {f['median']:.1f} | {f['p90']:.1f} | {f['p95']:.1f} "
            f"| {f['max']:.1f} | {100 * f['within_20']:.1f} % | {100 * f['within_50']:.1f} % |"
        )
    every = figures["all"]
    met = every["median"] <= TARGET_MEDIAN_MS and every["p90"] <= TARGET_P90_MS
    signed = float(np.median(errors))
    lines += [
        "",
        f"Median signed error (ours - GRID's): {signed:+.1f} ms.",
        f"Target (median <= {TARGET_MEDIAN_MS:.0f} ms, p90 <= {TARGET_P90_MS:.0f} ms): "
        + ("met." if met else "NOT met."),
        "",
        f"Seconds per clip (mean, after the first): {seconds['per_clip']:.3f} "
        f"(decoding the audio {seconds['decode']:.3f}, aligning {seconds['align']:.3f}); "
        f"the first clip, loading the aligner's model too: {seconds['first']:.2f} s.",
        "",
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Align a pool's clips and compare with GRID's word timings.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (``sys.argv[1:]`` by default).

    Returns
    -------
    int
        0 on success, 1 on a MiketalkError (printed on stderr).
    """
    parser = bench_parser(__name__, __doc__, limit_help="align the first N clips only")
    parser.add_argument("--pool", type=Path, required=True, help="a GRID-style folder")
    parser.add_argument("--out", type=Path, required=True, help="folder for the CSV and summary")
    return run_bench(parser, argv, _run)


def _run(args: argparse.Namespace) -> str:
    """Align the clips, write the table and the summary; return the summary."""
    clips = _pool_clips(args.pool)[: args.limit]
    rows: list[dict[str, object]] = []
    decode_s: list[float] = []
    align_s: list[float] = []
    for clip, words in clips:
        grid = read_word_timings(args.pool / "align" / f"{clip}.align")
        if [w.word.lower() for w in grid] != [w.lower() for w in words]:
            raise MiketalkError(f"{clip}: the .align words differ from the transcript")
        t0 = time.perf_counter()
        samples = read_media_audio(args.pool / "video" / f"{clip}.mpg", rate=16000)
        t1 = time.perf_counter()
        result = align(samples, 16000, words)
        t2 = time.perf_counter()
        decode_s.append(t1 - t0)
        align_s.append(t2 - t1)
        rows += _boundaries(clip, result.words, grid)
    n = len(clips)
    # the first clip also loads the aligner's model: its time is shown apart
    rest = slice(1, None) if n > 1 else slice(None)
    seconds = {
        "per_clip": float(np.mean(np.add(decode_s, align_s)[rest])),
        "decode": float(np.mean(decode_s[rest])),
        "align": float(np.mean(align_s[rest])),
        "first": decode_s[0] + align_s[0],
    }
    args.out.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    (args.out / "boundaries.csv").write_text(buffer.getvalue(), "utf-8")
    summary = _summary(rows, n, seconds)
    (args.out / "summary.md").write_text(summary, "utf-8")
    return summary


if __name__ == "__main__":
    sys.exit(main())
