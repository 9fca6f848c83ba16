"""docs/results.md from the measured tables (miketalk_lab.bench.results_doc): small fake tables
in the shapes the workflow and the bench write, the page made from them, its numbers checked;
a table not there is named as not measured, never filled in."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd
import pytest

from miketalk_lab.bench import results_doc

MODEL = "bergen/bridge"

#: Per clip and renderer (mouth_lmd, lip_opening_corr_speech, lip_opening_amplitude_speech,
#: eigenlip1_corr_speech, psnr_mouth, lip_opening_lag) on clips a, b, c.
MEASURES = {
    "morph": [(2.0, 0.60, 0.70, 0.10, 25.0, 0), (2.2, 0.62, 0.72, 0.12, 26.0, 0),
              (2.4, 0.64, 0.74, 0.14, 27.0, 1)],
    "still": [(2.6, 0.0, 0.0, 0.0, 24.0, 0), (2.7, 0.0, 0.0, 0.0, 24.5, 0),
              (2.8, 0.0, 0.0, 0.0, 25.0, 0)],
    "learned": [(1.9, 0.66, 0.80, 0.20, 25.5, 0), (2.1, 0.68, 0.82, 0.22, 26.5, 0),
                (2.3, 0.70, 0.84, 0.24, 27.5, 0)],
    "trained_heard": [(1.1, 0.71, 0.95, 0.41, 25.1, 0), (1.3, 0.73, 0.97, 0.43, 26.1, 1),
                      (1.5, 0.75, 0.99, 0.45, 27.1, -1)],
}  # fmt: skip


def _heldout_clips(path: Path) -> None:
    """A held-out ``clips.csv`` (heldout_stage's columns: clip, renderer, model, the measures)."""
    rows = []
    for renderer, values in MEASURES.items():
        for clip, (lmd, r, amp, eig, psnr, lag) in zip("abc", values, strict=True):
            rows.append({
                "clip": clip, "renderer": renderer, "model": MODEL, "frames": 75,
                "psnr_mouth": psnr, "ssim_mouth": 0.8, "sharpness_ratio": 0.7,
                "opening_corr": r, "opening_lag": lag, "eigenlip1_corr": eig,
                "eigenlip1_corr_speech": eig, "mouth_lmd": lmd, "mouth_lmd_speech": lmd,
                "lip_opening_corr_speech": r, "lip_opening_amplitude_speech": amp,
                "mouth_width_corr_speech": 0.3, "lip_opening_corr": r, "lip_opening_lag": lag,
            })  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(path, index=False)


def _tables(root: Path) -> tuple[Path, Path]:
    """``make run``'s tree and the bench's output, with one table of each kind (not all)."""
    results, bench = root / "results", root / "results" / "bench"
    _heldout_clips(results / "metrics" / "heldout" / "s1" / "clips.csv")
    corpus = results / "corpus" / "s1"
    corpus.mkdir(parents=True)
    pd.DataFrame({"clip": ["t1", "t2", "t3", "t4"], "frames": 75}).to_csv(
        corpus / "clips.tsv", sep="\t", index=False
    )
    metrics = results / "metrics"
    pd.DataFrame({
        "method": ["bergen", "bergen"], "estimator": ["bergen", "bergen"], "levels": [5, 5],
        "strategy": ["bridge", "bridge"], "region": ["mouth", "valid"],
        "mean_epe": [1.2345, 0.4321], "pct_over_1px": [33.3, 12.5], "pct_over_3px": [4.5, 1.25],
    }).to_csv(metrics / "flow_epe_summary.csv", index=False)  # fmt: skip
    pd.DataFrame({
        "sentence": ["hello"], "sampling": ["blur"], "fps": [30], "max_px_per_frame": [2.5],
        "frames": [42], "psnr_mouth": [31.25], "psnr_full": [40.0], "identical_frames": [0],
        "mouth_lag_frames": [0], "mouth_opening_corr": [0.9876],
        "max_abs_viseme_offset_frames": [0.5], "visemes_within_half_frame": [1.0],
        "largest_step_px_plain": [7.5], "largest_step_px_oversampled": [2.25],
        "duration_ratio": [1.0], "largest_frame_motion_px": [2.5],
    }).to_csv(metrics / "sync_summary.csv", index=False)  # fmt: skip
    dub = metrics / "dub" / "s1"
    dub.mkdir(parents=True)
    columns = {f"{c}_{s}": 0.5 for c in results_doc.DUB_COLUMNS for s in ("mean", "sd")}
    columns |= {"psnr_frame_mean": 38.8563, "psnr_frame_sd": 2.004}
    pd.DataFrame([columns | {"clips": 8, "renderer": "trained_heard"}]).to_csv(
        dub / "summary.csv", index=False
    )
    bench.mkdir(parents=True)
    summary = {"morph": {"morph_512_seconds": 0.01234, "bench_seconds": 4.5},
               "flow": {"bergen_epe_256": 0.3217}}  # fmt: skip
    (bench / "summary.json").write_text(json.dumps(summary))
    (bench / "one_video").mkdir()
    (bench / "one_video" / "summary.md").write_text(
        "# One video\n\n| script | <= 50 ms |\n| --- | --- |\n| transcript | 0.9123 |\n"
    )
    return results, bench


def test_numbers_of_the_tables_appear(tmp_path: Path) -> None:
    results, bench = _tables(tmp_path)
    page = results_doc.results_markdown(results, bench, tmp_path / "none", date="2000-01-01")
    # held out: 3 clips, 4 training clips (clips.tsv), mean ± sd over clips and paired margins
    assert "### s1, `make run`: 3 held-out clips, model from 4 training clips" in page
    row = next(ln for ln in page.splitlines() if ln.startswith("| trained_heard | 3 |"))
    assert "1.300 ± 0.200" in row  # mouth LMD 1.1, 1.3, 1.5
    assert "0.970 ± 0.020" in row  # amplitude
    paired = next(ln for ln in page.splitlines() if ln.startswith("| trained_heard − morph |"))
    assert "-0.900 (sd 0.000)" in paired and "+0.110 (sd 0.000)" in paired
    learned = next(ln for ln in page.splitlines() if ln.startswith("| trained_heard − learned |"))
    assert "-0.800 (sd 0.000)" in learned
    # the targets: opening r 0.730 met, LMD 1.300 met, PSNR +0.100 dB paired, lag 100 %
    assert "| opening r ≥ 0.70 | **0.730** |" in page
    assert "| first eigenlip r ≥ 0.4 | **0.430** |" in page
    assert "**+0.100 ± 0.000 dB**" in page and "| **100%** |" in page
    # the synthetic face's tables and the bench's, each with its command and source
    assert "| bergen | bergen | 5 | bridge | mouth | 1.234 | 33.3 | 4.5 |" in page
    assert f"read from `{results / 'metrics' / 'flow_epe_summary.csv'}`" in page
    assert "`snakemake --cores all results/metrics/flow_epe.csv`" in page
    assert "| hello | blur | 30 | 2.5 | 42 | 31.25 |" in page
    assert "| trained_heard | 8 | 38.856 ± 2.004 | 0.500 ± 0.500 |" in page
    assert "| morph | morph_512_seconds | 0.01234 |" in page
    assert "| flow | bergen_epe_256 | 0.3217 |" in page
    assert "| transcript | 0.9123 |" in page and "#### One video" in page
    assert "`python -m miketalk_lab.bench.heldout_table" in page


def test_missing_tables_are_named_not_invented(tmp_path: Path) -> None:
    results, bench = _tables(tmp_path)
    nowhere = tmp_path / "bench_workflow" / "results"
    page = results_doc.results_markdown(results, bench, nowhere, date="2000-01-01")
    for path in (
        nowhere / "metrics" / "heldout" / "s1" / "clips.csv",
        nowhere / "metrics" / "heldout" / "s1-n160" / "clips.csv",
        nowhere / "metrics" / "heldout" / "s1" / "training_clips.csv",
        nowhere / "metrics" / "dub" / "s1" / "summary.csv",
        results / "metrics" / "morph_fidelity_summary.csv",
        results / "metrics" / "sync_sweep_summary.csv",
        bench / "real_face" / "aligner" / "summary.md",
        bench / "anyone" / "summary.md",
        bench / "speed" / "summary.md",
    ):
        assert f"not measured in this run: `{path}`" in page
    assert page.count("not measured in this run:") == 12
    # the present tables are not reported missing, and nothing is made up for the absent ones
    assert f"not measured in this run: `{results / 'metrics' / 'sync_summary.csv'}`" not in page
    assert "held-out clips, model from" in page
    assert page.count("held-out clips, model from") == 1


def test_the_page_is_written_and_the_bench_writes_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    results, _ = _tables(tmp_path)
    out = tmp_path / "docs" / "results.md"
    code = results_doc.main(
        ["--results", str(results), "--bench-results", str(tmp_path / "x"), "--out", str(out),
         "--note", "Tables of a baseline run."]
    )  # fmt: skip
    assert code == 0 and "1.300 ± 0.200" in out.read_text()
    assert "\nTables of a baseline run.\n" in out.read_text()
    # python -m miketalk_lab.bench (no benchmark left to run) rewrites the page at its end
    from miketalk_lab.bench import __main__ as bench_main

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(bench_main, "MODULES", ())
    page = tmp_path / "page.md"
    monkeypatch.setattr(
        sys, "argv", ["bench", "--out", "results/bench", "--results-doc", str(page)]
    )
    assert bench_main.main() == 0
    text = page.read_text()
    assert "| trained_heard | 3 | 1.300 ± 0.200 |" in text
    assert "read from `results/bench/summary.json`" in text
    monkeypatch.setattr(sys, "argv", ["bench", "--out", "results/bench", "--no-results-doc"])
    page.unlink()
    assert bench_main.main() == 0 and not page.exists()


def test_the_page_points_at_the_hand_timed_runs_it_does_not_hold(tmp_path: Path) -> None:
    """The runs timed by hand live in docs/timings.md, which no command rewrites; the page
    ``make bench`` rewrites links to it, and the link is to a page that exists."""
    results, bench = _tables(tmp_path)
    page = results_doc.results_markdown(results, bench, tmp_path / "none", date="2000-01-01")
    assert "[timings.md](timings.md)" in page
    docs = Path(results_doc.__file__).resolve().parents[3] / "docs"
    assert (docs / "timings.md").is_file()
    assert "[timings.md](timings.md)" in (docs / "results.md").read_text("utf-8")
