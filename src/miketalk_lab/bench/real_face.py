"""The real face on a bigger pool: aligner, stabilization, model build, held-out evaluation, say.

``run(out_dir)`` reads ``.bench/config.yaml`` (the workflow's configuration for
``make bench``: GRID talker s1's 40 training clips and 40 held-out clips from
the pool it names), then

1. the forced aligner against the pool's word timings (:mod:`miketalk_lab.bench.aligner`);
2. the stabilization's residual motion (:mod:`miketalk_lab.bench.stabilization`);
3. the workflow on that configuration (``snakemake --directory .bench``): the s1
   model from 40 clips, the training-clips sweep and the held-out evaluation,
   with each rule's time from its benchmark file;
4. ``miketalk say`` of a 10-word sentence on the s1 model, warm (the paper's morph and
   the trained face), and ``say --audio`` of a held-out clip's own recording with the
   trained face, which hears it.

It returns the figures the issues set targets for.
"""

from __future__ import annotations

import csv
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import pandas as pd
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[3]
CONFIG = ROOT / ".bench" / "config.yaml"
SENTENCE = "Bin blue at F two now and lay green by G soon."


def _seconds(benchmark: pathlib.Path) -> float:
    with benchmark.open() as f:
        return float(next(csv.DictReader(f, delimiter="\t"))["s"])


#: The held-out measures the bench reports per renderer (mean and spread over clips, and
#: paired with the morph): the landmarks', the first eigenlip's, and the mouth's pixels (PSNR
#: beside the sharpness that PSNR rewards the want of).
RENDERER_FIGURES = (
    "mouth_lmd",
    "lip_opening_corr_speech",
    "lip_opening_amplitude_speech",
    "mouth_width_corr_speech",
    "eigenlip1_corr_speech",
    "psnr_mouth",
    "sharpness_ratio",
)

#: Renderers whose landmark figures the bench leaves out (the image baselines).
BASELINES = ("still", "flipbook", "dissolve")


def own_model(table: pd.DataFrame) -> str:
    """The face's own model in a held-out table: the one its baselines (``still``) draw."""
    still = table.loc[table["renderer"] == "still", "model"]
    if still.empty:
        raise ValueError("a held-out table without the still baseline names no own model")
    return str(still.iloc[0])


def landmark_figures(clips: pd.DataFrame, own: str) -> dict[str, float]:
    """The held-out measures of each lip-sync renderer of the face's own model.

    Per renderer (the baselines left out; the calibration rows ``real_late1``,
    ``real_late2`` kept): the mean and spread over clips of each of
    :data:`RENDERER_FIGURES`, its clip-by-clip difference from the paper's
    morph, and the fraction of clips whose opening lag is within one frame.
    """
    rows = clips[(clips["model"] == own) & ~clips["renderer"].isin(BASELINES)]
    morph = rows[rows["renderer"] == "morph"].set_index("clip")
    figures: dict[str, float] = {}
    for renderer, part in rows.groupby("renderer", sort=False):
        part = part.set_index("clip")
        for measure in RENDERER_FIGURES:
            figures[f"{renderer}_{measure}_mean"] = float(part[measure].mean())
            figures[f"{renderer}_{measure}_sd"] = float(part[measure].std(ddof=1))
            if renderer != "morph":
                margin = part[measure] - morph[measure].reindex(part.index)
                figures[f"{renderer}_minus_morph_{measure}_mean"] = float(margin.mean())
                figures[f"{renderer}_minus_morph_{measure}_sd"] = float(margin.std(ddof=1))
        within = (part["lip_opening_lag"].abs() <= 1).mean()
        figures[f"{renderer}_lip_opening_lag_within_1_fraction"] = float(within)
    return figures


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """Run every real-face benchmark; write their tables under ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    config = yaml.safe_load(CONFIG.read_text())
    corpus = config["faces"]["s1"]["corpus"]
    pool = (ROOT / corpus["transcripts"]).resolve().parent
    figures: dict[str, float] = {}

    from miketalk_lab.bench import aligner

    aligner.main(["--pool", str(pool), "--out", str(out_dir / "aligner")])
    boundaries = pd.read_csv(out_dir / "aligner" / "boundaries.csv")
    error = boundaries["error_ms"].abs()
    figures["aligner_median_ms"] = float(error.median())
    figures["aligner_p90_ms"] = float(error.quantile(0.9))

    from miketalk_lab.bench import stabilization

    stabilization.main(["--pool", str(pool), "--out", str(out_dir / "stabilization")])
    table = pd.read_csv(out_dir / "stabilization" / "stabilization.csv")
    figures["stabilization_median_px"] = float(table["after_px"].median())
    figures["stabilization_p95_px"] = float(table["after_px"].quantile(0.95))

    workdir = ROOT / ".bench"
    start = time.monotonic()
    subprocess.run(
        [sys.executable, "-m", "snakemake", "--snakefile", str(ROOT / "Snakefile"),
         "--directory", str(workdir), "--cores", "2", "--rerun-incomplete"],
        check=True,
    )  # fmt: skip
    figures["workflow_seconds"] = time.monotonic() - start
    bench = workdir / "results" / "benchmarks"
    build = [
        bench / "corpus" / "s1.tsv",
        bench / "visemes" / "s1.tsv",
        bench / "flows" / "s1" / "bergen" / "mixed.tsv",
        bench / "flows" / "s1" / "bergen" / "bridge.tsv",
    ]
    figures["s1_model_build_seconds"] = sum(_seconds(b) for b in build if b.exists())
    figures["heldout_seconds"] = _seconds(bench / "heldout" / "s1.tsv")

    summary = pd.read_csv(workdir / "results" / "metrics" / "heldout" / "s1" / "summary.csv")
    clips = pd.read_csv(workdir / "results" / "metrics" / "heldout" / "s1" / "clips.csv")
    own = own_model(clips)
    morph = clips[(clips["renderer"] == "morph") & (clips["model"] == own)].set_index("clip")
    figures["heldout_clips"] = float(len(morph))
    figures["eigenlip1_corr_mean"] = float(morph["eigenlip1_corr"].mean())
    figures["eigenlip1_lag_max_abs"] = float(morph["eigenlip1_lag"].abs().max())
    figures["psnr_mouth_mean"] = float(morph["psnr_mouth"].mean())
    for baseline in ("flipbook", "dissolve", "still"):
        other = clips[clips["renderer"] == baseline].set_index("clip")
        for measure in ("psnr_mouth", "eigenlip1_corr"):
            margin = morph[measure] - other[measure]
            figures[f"morph_minus_{baseline}_{measure}_mean"] = float(margin.mean())
            figures[f"morph_minus_{baseline}_{measure}_sd"] = float(margin.std(ddof=1))
    figures |= landmark_figures(clips, own)
    summary.to_csv(out_dir / "heldout_summary.csv", index=False)

    figures |= sweep_figures(workdir / "results" / "metrics" / "heldout" / "s1")
    figures |= dub_figures(workdir / "results" / "metrics" / "dub" / "s1" / "summary.csv")
    # the heard trajectory meeting other voices (Festival's, at his timing): R² by voice
    from miketalk_lab.bench.trajectory_cv import voice_scores

    by_voice = voice_scores(workdir / "results" / "corpus" / "s1", ("kal", "ked"), (300.0,))
    for voice, (whole, _) in by_voice[300.0].items():
        figures[f"heard_r2_{voice}"] = whole

    model = workdir / "results" / "model" / "s1"
    # a held-out clip's own recording: the trained face hears it (the heard trajectory)
    clip = corpus["test"][0]
    recording = (ROOT / corpus["media"].format(id=clip)).resolve()
    from miketalk.corpus.clip_sources import read_transcripts

    words = read_transcripts(ROOT / corpus["transcripts"])
    runs = (
        ("s1_say_10_words", [SENTENCE, "--lipsync-model", "paper"]),
        ("s1_say_10_words_trained", [SENTENCE, "--lipsync-model", "trained"]),
        ("s1_say_audio_trained_heard",
         ["--audio", str(recording), "--text", words[clip], "--lipsync-model", "trained"]),
    )  # fmt: skip
    for label, arguments in runs:
        with tempfile.TemporaryDirectory() as tmp:
            times = []
            for i in range(4):
                t0 = time.monotonic()
                subprocess.run(
                    [str(pathlib.Path(sys.executable).parent / "miketalk"), "say", *arguments,
                     "--model", str(model), "-o", os.path.join(tmp, f"s{i}.mp4")],
                    check=True, capture_output=True,
                )  # fmt: skip
                times.append(time.monotonic() - t0)
        figures[f"{label}_first_seconds"] = times[0]
        figures[f"{label}_warm_seconds"] = min(times[1:])
    return figures


#: The held-out dubs' figures the bench keeps (``summary.csv`` columns, ``_mean`` left off).
DUB_FIGURES = (
    "psnr_frame", "seam_ratio", "dub_mouth_lmd", "dub_lip_opening_corr_speech",
    "dub_lip_opening_amplitude_speech", "dub_sharpness_ratio", "roundtrip_sharpness_ratio",
    "jitter_beyond",
)  # fmt: skip


def dub_figures(summary_csv: pathlib.Path) -> dict[str, float]:
    """The held-out dubs' means (:data:`DUB_FIGURES`), named ``dub_...`` (nothing without)."""
    if not summary_csv.exists():
        return {}
    row = pd.read_csv(summary_csv).iloc[0]
    return {f"dub_{k.removeprefix('dub_')}": float(row[f"{k}_mean"]) for k in DUB_FIGURES}


def sweep_figures(heldout: pathlib.Path) -> dict[str, float]:
    """The training-clips sweep (``training_clips.csv``): per number of training clips, the
    landmark means of the paper's morph and the trained face, from the phones and hearing the
    recording (nothing without a sweep)."""
    path = heldout / "training_clips.csv"
    if not path.exists():
        return {}
    table = pd.read_csv(path)
    figures: dict[str, float] = {}
    own = own_model(table)
    shown = table["renderer"].isin(("morph", "trained", "trained_heard")) & (table["model"] == own)
    for row in table[shown].itertuples(index=False):
        for measure in RENDERER_FIGURES:
            key = f"sweep_n{row.training_clips}_{row.renderer}_{measure}_mean"
            figures[key] = float(getattr(row, f"{measure}_mean"))
    return figures
