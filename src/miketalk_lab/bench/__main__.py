"""``python -m miketalk_lab.bench --out DIR``: every benchmark, one summary table.

Each benchmark module has ``run(out_dir) -> dict[str, float]``; this runs them in
turn, each in its own process (so one core-pinned benchmark does not affect the
next), and writes ``summary.json`` and ``summary.md`` to ``DIR`` so a regression
shows in a diff. At the end it rewrites ``docs/results.md`` from every table measured
(:func:`miketalk_lab.bench.results_doc.write_results_doc`; ``--results-doc PATH`` writes it
elsewhere, ``--no-results-doc`` not at all).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from miketalk import defaults
from miketalk.media.atomic import write_text_atomic

#: The project's root (``docs/results.md`` is under it).
ROOT = Path(__file__).resolve().parents[3]

MODULES = (
    "synth_face", "flow", "morph", "pipeline", "sampling", "real_face", "one_video",
    "responsiveness", "anyone", "recognized_phones", "recognized_build", "speed",
    "live_page", "stop", "hour_memory",
)  # fmt: skip


def main() -> int:
    """Run the benchmarks named on the command line (default: all)."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench")
    parser.add_argument("--out", type=Path, default=defaults.RESULTS / "bench")
    parser.add_argument(
        "--results-doc", type=Path, default=ROOT / "docs" / "results.md",
        help="the page of measured tables rewritten at the end (default docs/results.md)",
    )  # fmt: skip
    parser.add_argument("--no-results-doc", action="store_true", help="leave it as it is")
    parser.add_argument("only", nargs="*", help=f"benchmarks to run, of: {' '.join(MODULES)}")
    args = parser.parse_args()
    unknown = sorted(set(args.only) - set(MODULES))
    if unknown:
        parser.error(f"unknown benchmark(s): {' '.join(unknown)}")
    args.out.mkdir(parents=True, exist_ok=True)
    summary: dict[str, dict[str, float]] = {}
    for name in args.only or MODULES:
        start = time.monotonic()
        code = (
            "import json, pathlib, sys\n"
            "from miketalk.workers import one_blas_thread\n"
            f"from miketalk_lab.bench.{name} import run\n"
            "with one_blas_thread():  # as the command line runs\n"
            f"    figures = run(pathlib.Path({str(args.out / name)!r}))\n"
            "print('@@' + json.dumps(figures))\n"
        )
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        sys.stdout.write(proc.stdout.replace("@@", "figures: ", 1) if proc.stdout else "")
        if proc.returncode != 0:
            sys.stderr.write(proc.stderr)
            print(f"benchmark {name} FAILED", file=sys.stderr)
            return 1
        line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("@@"))
        summary[name] = json.loads(line[2:])
        summary[name]["bench_seconds"] = round(time.monotonic() - start, 1)
    write_text_atomic(args.out / "summary.json", json.dumps(summary, indent=1, sort_keys=True))
    lines = ["| benchmark | figure | value |", "| --- | --- | --- |"]
    for name, figures in summary.items():
        lines += [f"| {name} | {k} | {v:.4g} |" for k, v in sorted(figures.items())]
    table = "\n".join(lines) + "\n"
    write_text_atomic(args.out / "summary.md", table)
    print(table)
    if not args.no_results_doc:
        from miketalk_lab.bench.results_doc import write_results_doc

        page = write_results_doc(args.results_doc, defaults.RESULTS, args.out)
        print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
