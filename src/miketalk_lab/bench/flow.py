"""Benchmark of the flow estimators (paper section 5.2) on one core: speed and accuracy.

``run(out_dir)`` times every registered estimator on the 256x256 textured
sinusoidal pair (:func:`miketalk_lab.evaluation.flow_error.sinusoidal_pair`, 4-pixel flow) with the
process pinned to one CPU and OpenCV on one thread (median of several calls,
after a warm-up call), scores each against the pair's ground truth, and runs
the Middlebury motorcycle stereo pair (:func:`miketalk_lab.evaluation.flow_error.motorcycle_table`,
also one thread), writing that table to ``motorcycle_epe.csv``. Run it with
``python -m miketalk_lab.bench.flow --out DIR``.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import cv2

from miketalk import defaults
from miketalk.flow import ESTIMATORS
from miketalk.media.atomic import atomic_path, write_text_atomic
from miketalk_lab.evaluation.flow_error import endpoint_error, motorcycle_table, sinusoidal_pair

SIZE = 256
# what `make run` leaves (the default config): the viseme images, the recording, true flows
VISEMES = defaults.visemes_dir("synthetic")
FRAMES = defaults.corpus_dir("synthetic") / "frames"
TRUTH = defaults.truth_dir("synthetic")
_BUDGET_SECONDS = 2.0  # per estimator on the 256² pair, beyond the minimum of runs
_MIN_RUNS, _MAX_RUNS = 3, 21


@contextmanager
def one_core() -> Iterator[None]:
    """Pin the process to one CPU and OpenCV to one thread; restore afterwards."""
    affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    threads = cv2.getNumThreads()
    try:
        if affinity:
            os.sched_setaffinity(0, {min(affinity)})
        cv2.setNumThreads(1)
        yield
    finally:
        if affinity:
            os.sched_setaffinity(0, affinity)
        cv2.setNumThreads(threads)


def _median_seconds(call: Callable[[], object]) -> float:
    """Median wall time of ``call()``: a warm-up call, then 3 to 21 timed calls (~2 s)."""
    call()
    times: list[float] = []
    spent = 0.0
    while len(times) < _MIN_RUNS or (spent < _BUDGET_SECONDS and len(times) < _MAX_RUNS):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
        spent += times[-1]
    return statistics.median(times)


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """Time and score every estimator; print a table; write ``flow.json``, ``motorcycle_epe.csv``.

    Parameters
    ----------
    out_dir : pathlib.Path
        Where the two files go (created if missing).

    Returns
    -------
    dict of str to float
        Per estimator ``NAME``: ``NAME_seconds_256`` (median seconds per 256²
        pair, one core), ``NAME_epe_256`` (mean endpoint error on it, pixels),
        ``NAME_motorcycle_epe`` and ``NAME_motorcycle_seconds``.
    """
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    image_a, image_b, true_flow = sinusoidal_pair((SIZE, SIZE))
    figures: dict[str, float] = {}
    with one_core():
        for name, estimator in ESTIMATORS.items():
            flow = estimator(image_a, image_b)
            figures[f"{name}_epe_{SIZE}"] = endpoint_error(flow, true_flow)["mean_epe"]
            seconds = _median_seconds(lambda e=estimator: e(image_a, image_b))
            figures[f"{name}_seconds_{SIZE}"] = seconds
        table = motorcycle_table(threads=1)
    with atomic_path(out_dir / "motorcycle_epe.csv") as tmp:
        table.to_csv(tmp, index=False, float_format="%.4f")
    for row in table.itertuples():
        figures[f"{row.estimator}_motorcycle_epe"] = float(row.mean_epe)
        figures[f"{row.estimator}_motorcycle_seconds"] = float(row.seconds)
    _print_table(figures, table)
    if (VISEMES / "visemes.tsv").exists() and (TRUTH / "flows").is_dir():
        figures |= viseme_pairs(out_dir)
    write_text_atomic(out_dir / "flow.json", json.dumps(figures, indent=2, sort_keys=True) + "\n")
    return figures


def viseme_pairs(out_dir: pathlib.Path) -> dict[str, float]:
    """Every estimator applied directly to the 240 viseme pairs of ``make run``'s face.

    Beside them, every method x strategy of the run's ``flow_epe.csv`` (the
    model's flows among them). Writes the mean
    endpoint error per estimator x strategy x region to ``viseme_pairs_epe.csv``
    and returns ``viseme_pairs_<estimator>_<strategy>_<region>_epe`` figures.
    """
    import tempfile

    import pandas as pd

    from miketalk.flow.build import build_flow_database
    from miketalk_lab.evaluation.tables import flow_epe_table

    visemes = pd.read_csv(VISEMES / "visemes.tsv", sep="\t", keep_default_na=False)
    tables = []
    run_table = defaults.metrics_dir() / "flow_epe.csv"
    if run_table.exists():
        tables.append(pd.read_csv(run_table))
    with tempfile.TemporaryDirectory() as tmp:
        for name in ESTIMATORS:
            flows = pathlib.Path(tmp) / name
            build_flow_database(
                flows, visemes=visemes, images_dir=VISEMES / "images", frames_dir=FRAMES,
                estimator=name, settings={}, strategy="direct", workers=2,
            )  # fmt: skip
            table = flow_epe_table(
                flows, TRUTH / "flows", TRUTH / "mouth_mask.png", method=f"{name} (defaults)",
                estimator=name, settings={}, strategy="direct",
            )  # fmt: skip
            tables.append(table)
    epe = pd.concat(tables)
    summary = (
        epe.groupby(["method", "strategy", "region"])[["mean_epe", "pct_over_1px", "pct_over_3px"]]
        .mean()
        .reset_index()
    )
    with atomic_path(out_dir / "viseme_pairs_epe.csv") as tmp_csv:
        summary.to_csv(tmp_csv, index=False, float_format="%.4f")
    wide = summary.pivot_table(index=["method", "strategy"], columns="region", values="mean_epe")
    print("\nviseme pairs (240 ordered): mean endpoint error (px), valid and mouth regions")
    print(wide.round(3).sort_values("mouth").to_string())
    return {
        f"viseme_pairs_{m}_{s}_{r}_epe".replace(" (defaults)", "_defaults"): float(v)
        for (m, s, r), v in summary.set_index(["method", "strategy", "region"])["mean_epe"].items()
        if m.endswith("(defaults)") or m == "bergen"  # our estimator, every strategy
    }


def _print_table(figures: dict[str, float], table: object) -> None:
    print(f"flow estimators, one core; {SIZE}² sinusoidal pair (4 px) and motorcycle (~500x740)")
    print(
        f"{'estimator':<14} {'ms/256²':>9} {'EPE 256²':>9} "
        f"{'moto EPE':>9} {'moto >1px%':>10} {'moto >3px%':>10} {'moto s':>8}"
    )
    for row in table.itertuples():  # type: ignore[attr-defined]
        name = row.estimator
        print(
            f"{name:<14} {1e3 * figures[f'{name}_seconds_{SIZE}']:>9.1f} "
            f"{figures[f'{name}_epe_{SIZE}']:>9.3f} {row.mean_epe:>9.3f} "
            f"{row.pct_over_1px:>10.1f} {row.pct_over_3px:>10.1f} {row.seconds:>8.2f}"
        )


def main() -> None:
    """``python -m miketalk_lab.bench.flow --out DIR``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=defaults.RESULTS / "bench" / "flow")
    run(parser.parse_args().out)


if __name__ == "__main__":
    main()
