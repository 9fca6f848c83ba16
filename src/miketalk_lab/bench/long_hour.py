"""An hour of a script read over and over, aligned whole: the words the long aligner leaves out.

``python -m miketalk_lab.bench.long_hour --grid DIR [--repeat 6] [--limit N] [--out OUT]
[--no-fill]`` joins the sound of the GRID clips of ``--grid`` (the benchmark pool's folder,
all its clips in name order, or the first ``--limit``) one after the other, ``--repeat``
times (the pool's 200 clips six times: 59.6 minutes, 7200 words), and aligns it with their
transcript as one plain text, as ``say --audio`` does
(:func:`miketalk.speech.long_align.align_long` alone, no fit limit). Prints the words left
out, their runs with why, the wall and CPU time of the alignment and the peak resident memory;
writes ``OUT/unplaced.tsv`` (each word left out, with why). ``--no-fill``: without the long
aligner's last pass (:mod:`miketalk.speech.long_fill`), for a paired comparison. Run it
under ``/usr/bin/time -v`` for the whole process's peak.
"""

from __future__ import annotations

import argparse
import resource
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from miketalk.media.atomic import write_text_atomic
from miketalk_lab.bench.command import bench_parser, run_bench


def main(argv: Sequence[str] | None = None) -> int:
    """Align the joined clips; see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="the pool's first N clips (all)")
    parser.add_argument("--grid", type=Path, required=True, help="GRID s1 clips' folder")
    parser.add_argument("--repeat", type=int, default=6, help="times the clips are joined (6)")
    parser.add_argument("--out", type=Path, default=Path("results/bench/long_hour"))
    parser.add_argument(
        "--no-fill", action="store_true", help="the long aligner without its last pass"
    )
    return run_bench(parser, argv, _run)


def _run(args: argparse.Namespace) -> str:
    from miketalk.corpus.clip_sources import RATE
    from miketalk.corpus.script import Cue, text_words
    from miketalk.media.decode import read_media_audio
    from miketalk.speech.long_align import align_long

    rows = (line.split(" ", 1) for line in (args.grid / "transcripts.txt").read_text().splitlines())
    text = {r[0]: r[1] for r in rows if len(r) == 2}
    ids = sorted(text)[: args.limit]
    one = np.concatenate(
        [read_media_audio(args.grid / "video" / f"{i}.mpg", rate=RATE) for i in ids]
    )
    samples = np.concatenate([one] * args.repeat)
    del one
    words = tuple(w for _ in range(args.repeat) for i in ids for w in text_words(text[i]))
    wall, cpu = time.perf_counter(), time.process_time()
    found = align_long(samples, RATE, [Cue(words)], fill=not args.no_fill)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    runs: list[list] = []
    for u in found.unaligned:
        if runs and runs[-1][1] == u.index - 1:
            runs[-1][1] = u.index
        else:
            runs.append([u.index, u.index, u.why])
    args.out.mkdir(parents=True, exist_ok=True)
    listed = ["index\tword\twhy", *(f"{u.index}\t{u.word}\t{u.why}" for u in found.unaligned)]
    write_text_atomic(args.out / "unplaced.tsv", "\n".join(listed) + "\n")
    lines = [
        f"{len(samples) / RATE:.0f} s, {len(words)} words, fill {not args.no_fill}: "
        f"{len(found.unaligned)} unplaced, alignment {wall:.0f} s wall, {cpu:.0f} s CPU, "
        f"peak resident {peak:.0f} MB",
        *(f"words {a + 1}-{b + 1} ({b - a + 1}): {why}" for a, b, why in runs),
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
