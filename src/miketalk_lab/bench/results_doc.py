"""``docs/results.md``, written from the tables ``make run`` and ``make bench`` measured.

``python -m miketalk_lab.bench.results_doc [--results results] [--bench-out results/bench]
[--bench-results .bench/results] [--out docs/results.md]`` reads, from three trees, whatever
tables exist and writes them as Markdown, each with the command that produced it and the file
it was read from:

- ``--results``: ``make run``'s tree (the held-out clips of each face, its dubs, and the
  synthetic face's flow error, morph fidelity and lip-sync tables under ``metrics/``);
- ``--bench-out``: what ``python -m miketalk_lab.bench --out DIR`` writes (``summary.json``,
  the timings among its figures, and the aligner, stabilization, one-video and flow benches'
  own tables);
- ``--bench-results``: the bench workflow's tree (``snakemake --directory .bench``: the 40
  held-out clips, the model from 40 and from 160 asked training clips, the training-clips
  sweep, the dubs).

A table that is not there is named in a line ``not measured in this run: <path>``; nothing is
ever filled in. ``make bench`` calls :func:`write_results_doc` at its end
(:mod:`miketalk_lab.bench.__main__`), so the page cannot drift from what was measured.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

#: The project's root (``docs/``, ``.bench/`` and ``Makefile`` are here).
ROOT = Path(__file__).resolve().parents[3]

#: The held-out faces of ``make run`` and of the bench workflow, and the bench's largest
#: training-clips sweep face (``.bench/config.yaml``: ``sweeps.training_clips``).
FACES = ("s1",)
BENCH_FACES = ("s1", "s1-n160")
#: The link to the runs timed by hand, kept in a page no command rewrites.
HAND_TIMED = "Runs timed by hand, quiet or paired before and after: [timings.md](timings.md)."

#: The bench workflow, as the held-out tables of the bench are made.
BENCH_SNAKEMAKE = (
    "snakemake --directory .bench --configfile .bench/config.yaml --cores 2 --rerun-incomplete"
)

#: Per-clip measures of a held-out ``clips.csv`` checked against the issue's targets:
#: (measure, label, test of the renderer's mean over clips). The mouth PSNR (paired with the
#: morph) and the opening lag are checked apart (:func:`_targets`).
TARGETS = (
    ("lip_opening_corr_speech", "opening r ≥ 0.70", lambda v: v >= 0.70),
    ("lip_opening_amplitude_speech", "amplitude 0.9 to 1.1", lambda v: 0.9 <= v <= 1.1),
    ("mouth_lmd", "mouth LMD ≤ 1.7 px", lambda v: v <= 1.7),
    ("eigenlip1_corr_speech", "first eigenlip r ≥ 0.4", lambda v: v >= 0.4),
)

#: Mean columns of a dub ``summary.csv`` shown (``_mean`` and ``_sd`` are in the file).
DUB_COLUMNS = (
    "psnr_frame", "seam_ratio", "dub_mouth_lmd", "dub_lip_opening_corr_speech",
    "dub_lip_opening_amplitude_speech", "dub_sharpness_ratio", "roundtrip_sharpness_ratio",
    "jitter_beyond",
)  # fmt: skip

#: Columns of a sync summary shown (``sync_summary.csv``, ``sync_sweep_summary.csv``).
SYNC_COLUMNS = (
    "sentence", "sampling", "fps", "max_px_per_frame", "frames", "psnr_mouth",
    "mouth_lag_frames", "mouth_opening_corr", "max_abs_viseme_offset_frames",
    "visemes_within_half_frame", "largest_step_px_plain", "largest_step_px_oversampled",
    "duration_ratio", "largest_frame_motion_px",
)  # fmt: skip

#: Held-out sweep measures shown per number of training clips (``training_clips.csv``).
SWEEP_COLUMNS = (
    "lip_opening_corr_speech", "lip_opening_amplitude_speech", "mouth_width_corr_speech",
    "eigenlip1_corr_speech", "mouth_lmd", "psnr_mouth",
)  # fmt: skip


def _shown(path: Path) -> str:
    """A path as the page shows it: relative to the working directory when under it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _missing(path: Path) -> str:
    return f"not measured in this run: `{_shown(path)}`"


def _cell(value: object) -> str:
    """A table cell: integers as they are, other numbers to 4 significant digits."""
    if isinstance(value, float):
        if math.isnan(value):
            return ""
        return f"{value:.0f}" if value.is_integer() and abs(value) < 1e6 else f"{value:.4g}"
    return str(value)


def markdown_table(table: pd.DataFrame) -> str:
    """A DataFrame as a Markdown table (numbers by :func:`_cell`)."""
    lines = ["| " + " | ".join(map(str, table.columns)) + " |"]
    lines.append("|" + " --- |" * len(table.columns))
    for row in table.itertuples(index=False):
        lines.append("| " + " | ".join(_cell(v) for v in row) + " |")
    return "\n".join(lines)


def _provenance(command: str, source: Path) -> str:
    return f"Made by `{command}`; read from `{_shown(source)}`."


def _csv_section(title: str, path: Path, command: str, columns: Sequence[str] = ()) -> list[str]:
    """A section of one CSV table, ``columns`` of it (all when empty), or its absence."""
    lines = [f"### {title}", ""]
    if not path.is_file():
        return [*lines, _missing(path), ""]
    table = pd.read_csv(path, keep_default_na=False, na_values=[""])
    if columns:
        table = table[[c for c in columns if c in table.columns]]
    return [*lines, _provenance(command, path), "", markdown_table(table), ""]


def _own_model(clips: pd.DataFrame) -> str:
    """The face's own model in a held-out table: the one its baselines draw (or the only one)."""
    from miketalk_lab.bench.real_face import own_model

    try:
        return own_model(clips)
    except ValueError:
        return str(clips["model"].iloc[0])


def _training_clips(results: Path, face: str) -> str:
    """How many training clips the face's corpus kept (its ``clips.tsv``), if it is there."""
    table = results / "corpus" / face / "clips.tsv"
    if not table.is_file():
        return "an unrecorded number of"
    return str(len(pd.read_csv(table, sep="\t", keep_default_na=False)))


def _targets(clips: pd.DataFrame, model: str) -> str:
    """The issue's targets met or not, per trained renderer, from a held-out ``clips.csv``."""
    rows = clips[clips["model"] == model]
    morph = rows[rows["renderer"] == "morph"].set_index("clip")
    shown = [r for r in ("trained", "trained_heard") if r in set(rows["renderer"])]
    if not shown or morph.empty:
        return ""
    lines = ["| target | " + " | ".join(f"`{r}`" for r in shown) + " |"]
    lines.append("|" + " --- |" * (len(shown) + 1))
    parts = {r: rows[rows["renderer"] == r].set_index("clip") for r in shown}
    for measure, label, test in TARGETS:
        cells = []
        for r in shown:
            mean = float(parts[r][measure].mean())
            cells.append(f"**{mean:.3f}**" if test(mean) else f"{mean:.3f}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    cells = []
    for r in shown:
        diff = parts[r]["psnr_mouth"] - morph["psnr_mouth"].reindex(parts[r].index)
        text = f"{diff.mean():+.3f} ± {diff.std(ddof=1):.3f} dB"
        cells.append(f"**{text}**" if diff.mean() >= 0 else text)
    lines.append("| mouth PSNR ≥ the paper's morph (paired) | " + " | ".join(cells) + " |")
    cells = []
    for r in shown:
        within = float((parts[r]["lip_opening_lag"].abs() <= 1).mean())
        cells.append(f"**{within:.0%}**" if within >= 0.9 else f"{within:.0%}")
    lines.append("| lag within ±1 frame on ≥ 90% of clips | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def heldout_section(results: Path, face: str, measured_by: str, snakemake: str) -> list[str]:
    """One face's held-out tables (:mod:`miketalk_lab.bench.heldout_table`) and targets."""
    from miketalk_lab.bench.heldout_table import tables

    path = results / "metrics" / "heldout" / face / "clips.csv"
    if not path.is_file():
        return [f"### {face}, {measured_by}", "", _missing(path), ""]
    clips = pd.read_csv(path)
    model = _own_model(clips)
    n_test = clips["clip"].nunique()
    n_train = _training_clips(results, face)
    table = f"python -m miketalk_lab.bench.heldout_table {_shown(path)} --model {model}"
    lines = [
        f"### {face}, {measured_by}: {n_test} held-out clips, model from {n_train} training clips",
        "",
        f"Measured by `{snakemake} results/metrics/heldout/{face}/summary.csv`; "
        f"read from `{_shown(path)}`; tabulated as `{table}` does (mean ± sd over clips; "
        "paired: the clip-by-clip difference, mean and sd).",
        "",
    ]
    spread, paired = tables(clips, model=model)
    lines += [spread, "", paired, ""]
    if "learned" in set(clips["renderer"]):
        lines += [f"Paired against `learned` (`{table} --against learned`):", ""]
        lines += [tables(clips, model=model, against="learned")[1], ""]
    targets = _targets(clips, model)
    if targets:
        lines += ["Against the issue's targets (bold: met):", "", targets, ""]
    return lines


def sweep_section(results: Path, face: str, snakemake: str) -> list[str]:
    """The training-clips sweep of a face (``training_clips.csv``): its lip-sync renderers."""
    from miketalk_lab.evaluation.dub_heldout import DUB_RENDERERS

    path = results / "metrics" / "heldout" / face / "training_clips.csv"
    lines = [f"### {face}: how much video a model needs (the training-clips sweep)", ""]
    if not path.is_file():
        return [*lines, _missing(path), ""]
    table = pd.read_csv(path)
    model = _own_model(table)
    shown = table[(table["model"] == model) & table["renderer"].isin(DUB_RENDERERS)]
    columns = [f"{c}_mean" for c in SWEEP_COLUMNS if f"{c}_mean" in table.columns]
    shown = shown[["training_clips", "renderer", "clips", *columns]]
    shown = shown.sort_values(["renderer", "training_clips"], kind="stable")
    command = f"{snakemake} results/metrics/heldout/{face}/training_clips.csv"
    return [*lines, _provenance(command, path), "", markdown_table(shown), ""]


def dub_section(results: Path, face: str, measured_by: str, snakemake: str) -> list[str]:
    """The held-out dubs of a face (``metrics/dub/<face>/summary.csv``): mean ± sd."""
    path = results / "metrics" / "dub" / face / "summary.csv"
    lines = [f"### {face}, {measured_by}", ""]
    if not path.is_file():
        return [*lines, _missing(path), ""]
    summary = pd.read_csv(path)
    present = [c for c in DUB_COLUMNS if f"{c}_mean" in summary.columns]
    head = "| renderer | clips | " + " | ".join(present) + " |"
    rows = [head, "|" + " --- |" * (len(present) + 2)]
    for row in summary.to_dict("records"):
        cells = [
            f"{row[f'{c}_mean']:.3f} ± {row.get(f'{c}_sd', float('nan')):.3f}" for c in present
        ]
        rows.append(
            f"| {row.get('renderer', '')} | {_cell(row.get('clips', ''))} | "
            + " | ".join(cells)
            + " |"
        )
    command = f"{snakemake} results/metrics/dub/{face}/summary.csv"
    return [*lines, _provenance(command, path), "", "\n".join(rows), ""]


def _markdown_file(title: str, path: Path, command: str) -> list[str]:
    """A bench's own Markdown summary, its headings moved under the section's."""
    lines = [f"### {title}", ""]
    if not path.is_file():
        return [*lines, _missing(path), ""]
    body = [
        f"#### {ln.lstrip('#').strip()}" if ln.startswith("#") else ln
        for ln in path.read_text("utf-8").strip().splitlines()
    ]
    return [*lines, _provenance(command, path), "", *body, ""]


def bench_section(bench_out: Path) -> list[str]:
    """``make bench``'s figures (``summary.json``): the timings, then every other figure."""
    path = bench_out / "summary.json"
    command = f"python -m miketalk_lab.bench --out {_shown(bench_out)}"
    lines = ["### Timings", ""]
    if not path.is_file():
        return [*lines, _missing(path), ""]
    summary = json.loads(path.read_text("utf-8"))
    rows = [
        (bench, name, value)
        for bench, figures in summary.items()
        for name, value in sorted(figures.items())
    ]
    timed = pd.DataFrame(
        [r for r in rows if "seconds" in r[1]], columns=["benchmark", "figure", "seconds"]
    )
    other = pd.DataFrame(
        [r for r in rows if "seconds" not in r[1]], columns=["benchmark", "figure", "value"]
    )
    lines += [_provenance(command, path), "", markdown_table(timed), ""]
    lines += ["### Every other figure of the bench", "", _provenance(command, path), ""]
    return [*lines, "<details>", "", markdown_table(other), "", "</details>", ""]


def results_markdown(
    results: Path = Path("results"),
    bench_out: Path = Path("results") / "bench",
    bench_results: Path = ROOT / ".bench" / "results",
    *,
    faces: Sequence[str] = FACES,
    bench_faces: Sequence[str] = BENCH_FACES,
    date: str | None = None,
    note: str | None = None,
) -> str:
    """The page: every table found in the three trees, or a line naming it as not measured.

    Parameters
    ----------
    results : Path
        ``make run``'s results tree.
    bench_out : Path
        The folder ``python -m miketalk_lab.bench --out`` wrote.
    bench_results : Path
        The bench workflow's results tree (``.bench/results``).
    faces, bench_faces : sequence of str
        The held-out faces of ``make run`` and of the bench workflow.
    date : str, optional
        The day written in the header (default: today, UTC).
    note : str, optional
        A paragraph added to the header (where the tables come from, when it is not the
        usual ``make run`` and ``make bench`` of this checkout).

    Returns
    -------
    str
        The Markdown of ``docs/results.md``.
    """
    date = date or datetime.now(UTC).strftime("%Y-%m-%d")
    metrics = results / "metrics"
    run = "snakemake --cores all"
    bench = f"python -m miketalk_lab.bench --out {_shown(bench_out)}"
    lines = [
        "# Measured results",
        "",
        f"Written on {date} by `python -m miketalk_lab.bench.results_doc`, which `make bench` "
        "runs at its end: do not edit by hand. Every table says the command that made it and "
        "the file it was read from; a table this run did not make is named as not measured, "
        "never filled in. How each measure is defined, and what was decided from earlier "
        "measurements: [lipsync.md](lipsync.md), [dub.md](dub.md), [build.md](build.md), "
        "[faces.md](faces.md), [pipeline.md](pipeline.md).",
        "",
        f"Read from: `{_shown(results)}` (`make run`), `{_shown(bench_out)}` (`make bench`), "
        f"`{_shown(bench_results)}` (the bench workflow).",
        "",
        *([note, ""] if note else []),
        "## The real face: held-out clips",
        "",
        "Each held-out clip re-synthesized from its own audio and compared frame by frame with "
        "its stabilized video (dlib's landmarks; opening r and amplitude over the speech; "
        "`lip_opening_lag` within ±1: the share of clips whose opening lags by at most a frame).",
        "",
    ]
    for face in faces:
        lines += heldout_section(results, face, "`make run`", run)
    for face in bench_faces:
        lines += heldout_section(bench_results, face, "the bench workflow", BENCH_SNAKEMAKE)
    for face in bench_faces[:1]:
        lines += sweep_section(bench_results, face, BENCH_SNAKEMAKE)
    lines += ["## The real face: held-out clips dubbed with their own audio", ""]
    for face in faces:
        lines += dub_section(results, face, "`make run`", run)
    for face in bench_faces[:1]:
        lines += dub_section(bench_results, face, "the bench workflow", BENCH_SNAKEMAKE)
    lines += ["## A face from one video; the aligner; stabilization", ""]
    lines += _markdown_file(
        "One video (`miketalk build` on the bench's pool joined)",
        bench_out / "one_video" / "summary.md",
        f"{bench} one_video",
    )
    lines += _markdown_file("People other than s1: the weekly addresses ([anyone.md](anyone.md))",
                            bench_out / "anyone" / "summary.md", f"{bench} anyone")  # fmt: skip
    for title, part in (("Forced aligner against GRID's word timings", "aligner"),
                        ("Stabilization: residual motion", "stabilization")):  # fmt: skip
        lines += _markdown_file(title, bench_out / "real_face" / part / "summary.md",
                                f"{bench} real_face")  # fmt: skip
    lines += ["## The synthetic face: against ground truth", ""]
    if (metrics / "SKIPPED.txt").is_file():
        lines += [f"`{_shown(metrics / 'SKIPPED.txt')}`: "
                  + (metrics / "SKIPPED.txt").read_text("utf-8").strip(), ""]  # fmt: skip
    lines += _csv_section(
        "Flow endpoint error (px), by method, strategy and region",
        metrics / "flow_epe_summary.csv",
        f"{run} results/metrics/flow_epe.csv",
    )
    lines += _csv_section(
        "Flow endpoint error of every estimator on the viseme pairs (px)",
        bench_out / "flow" / "viseme_pairs_epe.csv",
        f"{bench} flow",
    )
    lines += _csv_section(
        "Flow on the Middlebury motorcycle pair",
        metrics / "motorcycle_epe.csv",
        f"{run} results/metrics/motorcycle_epe.csv",
    )
    lines += _csv_section(
        "Morph fidelity against the true in-between render",
        metrics / "morph_fidelity_summary.csv",
        f"{run} results/metrics/morph_fidelity.csv",
    )
    lines += _csv_section(
        "Lip-sync of the configured sentences",
        metrics / "sync_summary.csv",
        f"{run} results/metrics/sync.csv",
        SYNC_COLUMNS,
    )
    lines += _csv_section(
        "Lip-sync sweep (sampling, max px per frame, fps)",
        metrics / "sync_sweep_summary.csv",
        f"{run} results/metrics/sync_sweep.csv",
        SYNC_COLUMNS,
    )
    lines += ["## `make bench`", "", HAND_TIMED, ""]
    lines += _markdown_file("Speed: say, dub and the 720p render (issue 51's targets)",
                            bench_out / "speed" / "summary.md", f"{bench} speed")  # fmt: skip
    lines += bench_section(bench_out)
    return "\n".join(lines).rstrip() + "\n"


def write_results_doc(
    out: Path = ROOT / "docs" / "results.md",
    results: Path = Path("results"),
    bench_out: Path = Path("results") / "bench",
    bench_results: Path = ROOT / ".bench" / "results",
    **options,
) -> Path:
    """Write :func:`results_markdown` of the three trees to ``out`` (atomically); return it.

    Parameters
    ----------
    out : Path
        The page (``docs/results.md``).
    results, bench_out, bench_results : Path
        As :func:`results_markdown`.
    **options
        ``faces``, ``bench_faces``, ``date``, ``note`` (:func:`results_markdown`).
    """
    from miketalk.media.atomic import write_text_atomic

    text = results_markdown(results, bench_out, bench_results, **options)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, text)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m miketalk_lab.bench.results_doc``: rewrite ``docs/results.md``."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.results_doc")
    parser.add_argument("--results", type=Path, default=Path("results"), help="make run's tree")
    parser.add_argument("--bench-out", type=Path, default=None, help="default RESULTS/bench")
    parser.add_argument("--bench-results", type=Path, default=ROOT / ".bench" / "results")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "results.md")
    parser.add_argument("--note", help="a paragraph for the header: where the tables come from")
    args = parser.parse_args(argv)
    bench_out = args.bench_out or args.results / "bench"
    path = write_results_doc(args.out, args.results, bench_out, args.bench_results, note=args.note)
    print(f"wrote {os.fspath(path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
