"""The whole workflow end to end on the tiny .test configuration.

One run builds everything (corpus -> visemes -> flows -> model -> utterance ->
metrics -> figures); the tests then check outputs, metric bounds, that a rerun
has nothing to do, that stages rebuild byte-identically, and that a killed run
leaves nothing that a later run takes as complete.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from miketalk.speech import FestivalBackend

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = Path(sys.executable).parent / "snakemake"

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not FestivalBackend().is_available(), reason="Festival not installed"),
]


def snakemake(workdir: Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [str(SNAKEMAKE), "--snakefile", str(ROOT / "Snakefile"), "--directory", str(workdir),
         "--cores", "2", "--rerun-incomplete", *args],
        capture_output=True, text=True,
    )  # fmt: skip
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return proc


def with_video_face(workdir: Path, joined) -> None:
    """The .test config, plus s1's six clips joined into one video (conftest's ``s1_joined``)
    with its SRT of sentence cues: face ``s1video``, its last 6 s (s1's two test clips) held
    out."""
    import yaml

    config = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())
    config["faces"]["s1video"] = {
        "corpus": {
            "source": "video",
            "media": str(joined.video),
            "subtitles": str(joined.subtitles),
            "heldout_seconds": 6,
        },
        "frame": "full",
        "lipsync": {"model": "learned"},
    }
    (workdir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory, s1_joined) -> Path:
    workdir = tmp_path_factory.mktemp("workflow")
    with_video_face(workdir, s1_joined)
    snakemake(workdir)
    return workdir


def digest(paths: list[Path]) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(paths)}


def test_outputs_exist(run: Path) -> None:
    results = run / "results"
    for path in [
        "corpus/synthetic/corpus.mp4",
        "visemes/synthetic/contact_sheet.png",
        "model/synthetic/manifest.json",
        "utterances/synthetic/hello.mp4",
        "utterances/synthetic/hello.json",
        "metrics/flow_epe.csv",
        "metrics/morph_fidelity.csv",
        "metrics/sync.csv",
        "metrics/sync_sweep.csv",
        "figures/epe_vs_levels.png",
        "figures/morph_psnr_vs_alpha.png",
        "figures/sync_vs_max_px.png",
        "figures/sampling_vs_max_px.png",
        "figures/sampling_strip.png",
        "figures/lipsync_diagram.png",
        "figures/morph_strip.png",
        "corpus/s1/corpus.mp4",
        "visemes/s1/contact_sheet.png",
        "model/s1/manifest.json",
        "utterances/s1/hello.mp4",
        "metrics/heldout/s1/summary.csv",
        "heldout/s1/bbas3a.mp4",
        "heldout/s1/srau3s.mp4",
    ]:
        assert (results / path).stat().st_size > 0, path
    for face in ("synthetic", "s1"):
        assert len(list((results / f"visemes/{face}/images").glob("*.png"))) == 16


def test_a_real_face_from_four_clips(run: Path) -> None:
    """s1's model: whole stabilized frames, every class an image (its own or a named fallback)."""
    import json

    results = run / "results"
    clips = pd.read_csv(results / "corpus/s1/clips.tsv", sep="\t")
    assert list(clips["clip"]) == ["bbaf2n", "lgwg2n", "pric4p", "swih9a"]
    assert clips["frames"].sum() == len(list((results / "corpus/s1/frames").glob("*.png")))
    visemes = pd.read_csv(results / "visemes/s1/visemes.tsv", sep="\t", keep_default_na=False)
    manifest = json.loads((results / "model/s1/manifest.json").read_text())
    assert manifest["size"] == [288, 360]  # the whole frame, not a mouth crop
    fallbacks = {v: f for v, f in zip(visemes["viseme"], visemes["fallback"], strict=True) if f}
    assert manifest.get("fallbacks", {}) == fallbacks
    assert set(visemes["clip"]) <= set(clips["clip"])  # test clips never reach the model
    summary = pd.read_csv(results / "metrics/heldout/s1/summary.csv")
    assert set(summary["renderer"]) == {
        "morph", "still", "flipbook", "dissolve", "learned", "trained", "trained_regularized",
        "trained_previous", "trained_heard", "trained_pooled", "real_late1", "real_late2",
    }  # fmt: skip
    trained = json.loads((results / "model/s1/trained/trained.json").read_text())
    assert trained["default"] == "window" and trained["fit"]["clips"] == len(clips)
    assert set(trained["trajectories"]) == {"window", "regularized", "heard", "pooled"}
    assert (summary["clips"] == 2).all()
    assert summary["eigenlip1_corr_speech_mean"].between(-1, 1).all()
    # the landmark measures: the real mouth late is near, but not the real mouth
    rows = summary.set_index(["renderer", "model"])
    late1, late2 = (
        rows.loc[("real_late1", "bergen/bridge")],
        rows.loc[("real_late2", "bergen/bridge")],
    )
    assert 0 < late1["mouth_lmd_mean"] < late2["mouth_lmd_mean"]
    assert late1["lip_opening_corr_speech_mean"] < 1
    assert late1["lip_opening_lag_mean"] == 1 and late2["lip_opening_lag_mean"] == 2
    assert rows.loc[("still", "bergen/bridge"), "lip_opening_amplitude_speech_mean"] == 0
    assert rows.loc[("morph", "bergen/bridge"), "mouth_lmd_vs_morph_mean"] == 0
    assert summary["lip_opening_corr_speech_mean"].between(-1, 1).all()
    # the side-by-side videos show the three lip-sync models, and the strip is drawn from them
    side = json.loads((results / "heldout/s1/bbas3a.json").read_text())
    assert side["columns"] == ["real", "paper", "learned", "trained", "trained_heard"]
    assert (results / "figures/heldout/s1/strip.png").stat().st_size > 0
    # s1 speaks with what it learned (its config), at the speech's own speed
    said = json.loads((results / "utterances/s1/hello.json").read_text())
    assert said["lipsync_model"] == "learned"
    # the learned path keeps the step limit: more states drawn than frames where it moves fast
    assert said["motion"]["morphs"] >= said["motion"]["frames"]
    assert said["largest_step_px"] <= said["max_px_per_frame"] + 1e-6
    assert abs(said["motion"]["duration_ratio"] - 1) < 0.1
    # ... over its own frames (the model keeps 2 to 3 s of its reference clip, cut where
    # the head stands still), and the synthetic face stays still
    assert said["background"]["source"] == "clip bbaf2n"
    assert 50 <= said["background"]["frames"] <= 75
    assert "background" not in json.loads((results / "utterances/synthetic/hello.json").read_text())
    # the held-out clips dubbed with their own audio
    dub = pd.read_csv(results / "metrics/dub/s1/clips.csv")
    assert list(dub["clip"]) == ["bbas3a", "srau3s"]
    # dubbed as its lipsync.recording_model says: the trained face, hearing the recording
    assert (dub["renderer"] == "trained_heard").all()
    assert (dub["psnr_frame"] > 25).all() and dub["seam_ratio"].between(0.3, 3).all()
    # the dub's mouth landmarks against the real frames, beside the uncomposited render's
    assert (dub["dub_mouth_lmd"] > 0).all() and (dub["render_mouth_lmd"] > 0).all()
    assert dub["dub_lip_opening_corr_speech"].between(-1, 1).all()
    # the mouth's motion against the nose, real and dubbed (landmarks, px RMS a frame)
    assert dub["jitter_real"].between(0.05, 5).all() and dub["jitter_dub"].between(0.05, 5).all()
    assert np.allclose(dub["jitter_beyond"], dub["jitter_dub"] - dub["jitter_real"], atol=1e-4)
    assert (results / "dub/s1/srau3s.mp4").stat().st_size > 0
    assert (results / "figures/dub/s1/strip.png").stat().st_size > 0


def test_a_face_from_one_video(run: Path) -> None:
    """s1's clips joined into one video (SRT cues) in the workflow: the same utterances."""
    import json

    results = run / "results"
    segments = json.loads((results / "segments/s1video.json").read_text())
    assert segments["unaligned"] == []
    assert [u["split"] for u in segments["utterances"]] == ["train"] * 4 + ["test"] * 2
    clips = pd.read_csv(results / "corpus/s1video/clips.tsv", sep="\t")
    s1 = pd.read_csv(results / "corpus/s1/clips.tsv", sep="\t")
    assert list(clips["text"]) == list(s1["text"])
    assert (results / "model/s1video/manifest.json").exists()
    said = json.loads((results / "utterances/s1video/hello.json").read_text())
    assert said["background"]["source"] == f"clip {segments['utterances'][0]['id']}"
    assert len(pd.read_csv(results / "metrics/heldout/s1video/clips.csv")["clip"].unique()) == 2
    assert (results / "metrics/dub/s1video/summary.csv").exists()
    assert (results / "figures/heldout/s1video/strip.png").stat().st_size > 0


def one_video_face(run: Path, s1_built: Path, script: str) -> tuple[Path, dict, Path]:
    """The corpus, segments and model of s1's joined video: from its SRT by the workflow
    (face s1video), or from its plain transcript by ``miketalk build`` (conftest)."""
    import json

    results = run / "results"
    if script == "subtitles":
        segments = json.loads((results / "segments/s1video.json").read_text())
        return results / "corpus/s1video", segments, results / "model/s1video"
    segments = json.loads((s1_built / "build" / "segments.json").read_text())
    return s1_built.parent / "corpus", segments, s1_built


#: The phones of a corpus from the joined video against s1's from its clips (aligned inside
#: GRID's word timings): the same spoken phones, and their boundaries within the aligner's
#: accuracy: the issue's target for words (>= 90 % within 50 ms of GRID's) held to the phones,
#: and their median error within 30 ms.
PHONES_WITHIN_50MS, PHONES_MEDIAN_MS = 0.90, 30.0


@pytest.mark.parametrize("script", ["transcript", "subtitles"])
def test_one_video_phones_match_the_clips_corpus(
    run: Path, s1_built: Path, s1_joined, script: str
) -> None:
    from miketalk_lab.bench.video_vs_clips import phone_errors

    corpus, segments, _ = one_video_face(run, s1_built, script)
    assert segments["unaligned"] == []
    spans = pd.read_csv(s1_joined.clips, sep="\t")
    errors = phone_errors(corpus, segments, run / "results/corpus/s1", spans)
    assert errors["same_phones"].all(), errors[~errors["same_phones"]]
    assert sorted(set(errors["clip"])) == ["bbaf2n", "lgwg2n", "pric4p", "swih9a"]
    error = errors["error_ms"].abs()
    assert (error <= 50 + 1e-6).mean() >= PHONES_WITHIN_50MS, errors.sort_values("error_ms")
    assert error.median() <= PHONES_MEDIAN_MS, errors.sort_values("error_ms")


def heldout_gaps(clips_built: pd.DataFrame, video_built: pd.DataFrame) -> list[str]:
    """Where a model from the joined video falls outside the tolerances of s1's from its
    clips, on the same held-out clips, the mean of the paired difference (renderers morph
    and learned): mouth PSNR within 1 dB and mouth landmark distance within 0.5 px either
    way; the lip opening's correlation with the real one no more than 0.1 lower, its
    amplitude (as a share of the real one's) no more than 0.1 farther from 1."""
    from miketalk_lab.bench.video_vs_clips import compare_heldout

    table = compare_heldout(clips_built, video_built, model="bergen/bridge")
    gaps = []
    for renderer, part in table.groupby("renderer"):
        row = part.set_index("measure")
        diff = row["paired_diff_mean"]
        amplitude = row.loc["lip_opening_amplitude_speech"]
        farther = abs(1 - amplitude["video_built_mean"]) - abs(1 - amplitude["clips_built_mean"])
        for measure, ok in (
            ("psnr_mouth", abs(diff["psnr_mouth"]) <= 1.0),
            ("mouth_lmd", abs(diff["mouth_lmd"]) <= 0.5),
            ("lip_opening_corr_speech", diff["lip_opening_corr_speech"] >= -0.1),
            ("lip_opening_amplitude_speech", farther <= 0.1),
        ):
            if not ok:
                gaps.append(f"{renderer} {measure} {diff[measure]:+.3f}")
    assert set(table["renderer"]) == {"morph", "learned"}
    return gaps


@pytest.mark.parametrize("script", ["transcript", "subtitles"])
def test_one_video_model_matches_the_clips_model_on_held_out_clips(
    run: Path, s1_built: Path, script: str, tmp_path: Path
) -> None:
    """Both models measured on s1's two test clips (the clip files), each in its own
    corpus's frame, paired clip by clip (see :func:`heldout_gaps`)."""
    import yaml

    from miketalk.corpus.clip_sources import clip_sources
    from miketalk_lab.bench.video_vs_clips import heldout_of_model

    corpus, _, model = one_video_face(run, s1_built, script)
    s1 = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["faces"]["s1"]["corpus"]
    clips = clip_sources(
        s1["test"],
        media=str(ROOT / s1["media"]),
        transcripts=ROOT / s1["transcripts"],
        timings=str(ROOT / s1["timings"]),
    )
    video_built = heldout_of_model(model, corpus, clips, tmp_path, name="bergen/bridge")
    clips_built = pd.read_csv(run / "results/metrics/heldout/s1/clips.csv")
    assert heldout_gaps(clips_built, video_built) == []
    # the tolerances can fail: a still mouth (the clips-built model's still baseline) fails them
    still = clips_built[clips_built["renderer"] == "still"]
    as_models = pd.concat([still.assign(renderer=r) for r in ("morph", "learned")])
    assert len(heldout_gaps(clips_built, as_models)) >= 2


def test_metrics_within_bounds(run: Path) -> None:
    results = run / "results"
    targets = pd.read_csv(results / "visemes/synthetic/targets.tsv", sep="\t")
    assert targets["error"].abs().max() <= 1
    epe = pd.read_csv(results / "metrics/flow_epe.csv")
    model_flows = epe[(epe["method"] == "bergen") & (epe["strategy"] == "bridge")]
    assert len(model_flows) == 2 * 240
    assert model_flows[model_flows["region"] == "valid"]["mean_epe"].mean() < 1.0
    morph = pd.read_csv(results / "metrics/morph_fidelity.csv")
    mouth = morph[(morph["region"] == "mouth") & (morph["alpha"] == 0.5)]
    by = mouth.groupby("candidate")["psnr"].mean()
    assert by["morph_true_flow"] > by["cross_dissolve"]
    assert by["morph_estimated_flow"] > by["cross_dissolve"]
    assert morph["holes_left"].max() == 0
    sync = pd.read_csv(results / "metrics/sync_summary.csv").iloc[0]
    assert sync["mouth_lag_frames"] == 0
    assert abs(sync["duration_diff_frames"]) <= 1
    assert sync["largest_step_px_oversampled"] <= 2.5 + 1e-6
    assert sync["max_abs_viseme_offset_frames"] <= 0.5


def test_rerun_has_nothing_to_do(run: Path) -> None:
    proc = snakemake(run)
    assert "Nothing to be done" in proc.stdout + proc.stderr


def _reordered(value: object) -> object:
    """``value`` with every mapping's keys in reverse sorted order (lists as they are)."""
    if isinstance(value, dict):
        return {key: _reordered(value[key]) for key in sorted(value, reverse=True)}
    if isinstance(value, list):
        return [_reordered(item) for item in value]
    return value


@pytest.mark.parametrize("order", ["sorted", "reversed"])
def test_reordered_config_has_nothing_to_do(run: Path, order: str) -> None:
    """The same settings in another key order: the same params, nothing reruns."""
    import yaml

    config_file = run / "config.yaml"
    text = config_file.read_text()
    config = yaml.safe_load(text)
    reordered = (
        yaml.safe_dump(config, sort_keys=True)
        if order == "sorted"
        else yaml.safe_dump(_reordered(config), sort_keys=False)
    )
    assert reordered != text
    try:
        config_file.write_text(reordered)  # the config itself, not one merged onto it
        proc = snakemake(run, "--dry-run")
    finally:
        config_file.write_text(text)
    assert "Nothing to be done" in proc.stdout + proc.stderr, proc.stdout[-3000:]


def test_pyramid_depth_change_reruns_only_what_depends_on_it(run: Path, tmp_path: Path) -> None:
    """A dry run after changing flow.methods.bergen.settings.levels lists the jobs to redo."""
    import yaml

    config = yaml.safe_load((run / "config.yaml").read_text())
    config["flow"]["methods"]["bergen"]["settings"]["levels"] += 1
    changed = tmp_path / "levels.yaml"
    changed.write_text(yaml.safe_dump(config, sort_keys=False))  # as a person edits it
    proc = snakemake(run, "--configfile", str(changed), "--dry-run")
    out = proc.stdout + proc.stderr
    table = out.split("Job stats:")[1].split("\n\n")[0]
    rules = {line.split()[0] for line in table.splitlines()[3:] if len(line.split()) == 2}
    assert {"flows", "model", "utterance", "morph_fidelity", "sync"} <= rules
    # upstream of the flows, the truth and the depth sweep's own methods stay as they are
    assert not rules & {"corpus", "visemes", "true_flows", "motorcycle"}
    flows = re.findall(r"wildcards: method=([\w-]+), strategy=(\w+)", out)
    assert {method for method, _ in flows} == {"bergen"}  # not the sweep's bergen-L<n>
    assert {strategy for _, strategy in flows} == {"direct", "concat", "mixed", "bridge"}


def _dry_run_jobs(workdir: Path, *targets: str) -> dict[str, list[str]]:
    """Each rule's jobs in a dry run: their input and output lines."""
    proc = snakemake(workdir, "--dry-run", *targets)
    jobs: dict[str, list[str]] = {}
    for block in re.split(r"\n(?=rule \w+:)", proc.stdout):
        if match := re.match(r"rule (\w+):", block):
            lines = [
                ln.strip()
                for ln in block.splitlines()
                if ln.strip().startswith(("input", "output"))
            ]
            jobs.setdefault(match[1], []).append("\n".join(lines))
    return jobs


SWEPT = re.compile(r"results/utterances/synthetic/sweep/(\w+)/px([\d.]+)_fps([\d.]+)\.mp4")


@pytest.mark.parametrize(
    ("sweep", "made"),
    [
        # the .test config: one setting; blur there is the configured utterance
        ({}, {("paper", "2.5", "30")}),
        (
            {"max_px_per_frame": [1.5, 2.5], "fps": [30, 60]},
            {("blur", "1.5", "30"), ("blur", "2.5", "60"), ("paper", "1.5", "30"),
             ("paper", "2.5", "30"), ("paper", "2.5", "60")},
        ),
        ({"sampling": ["paper"]}, {("paper", "2.5", "30")}),
    ],
)  # fmt: skip
def test_sync_sweep_targets_in_both_sampling_modes(
    tmp_path: Path, sweep: dict, made: set[tuple[str, str, str]]
) -> None:
    """A dry run on the .test config: the sweep's utterances and tables, per sampling mode."""
    import yaml

    config = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())
    config["sweeps"] |= sweep
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    jobs = _dry_run_jobs(
        tmp_path, "results/figures/sampling_vs_max_px.png", "results/figures/sampling_strip.png"
    )
    utterances = {SWEPT.search(job).groups() for job in jobs["sweep_utterance"]}
    assert utterances == made
    (table,) = jobs["sync_sweep_table"]
    tables = set(re.findall(r"sync_sweep/synthetic/(\w+)/px([\d.]+)_fps([\d.]+)\.csv", table))
    assert tables == made
    # the configured point (blur, 2.5 px, 30 fps) is the sync rule's table of the sentence
    configured = "blur" in config["sweeps"]["sampling"]
    assert ("metrics/sync/synthetic/hello.csv" in table) == configured
    said = [
        re.search(r"utterances/(\w+)/(\w+)\.mp4", job).groups() for job in jobs.get("utterance", [])
    ]
    assert said == [("synthetic", "hello")] * configured
    (strip,) = jobs["figure_sampling_strip"]
    shown = re.findall(r"utterances/synthetic/(sweep/\w+/px2\.5_fps30|hello)\.json", strip)
    # a row per swept mode, at the configured max_px and fps: blur's is the configured utterance
    assert shown == [
        "hello" if m == "blur" else f"sweep/{m}/px2.5_fps30" for m in config["sweeps"]["sampling"]
    ]


def test_stages_rebuild_byte_identical(run: Path) -> None:
    results = run / "results"
    visemes = sorted((results / "visemes/synthetic").rglob("*.*"))
    flows = sorted((results / "flows/synthetic/bergen/bridge").glob("*.exr"))
    before = digest(visemes) | digest(flows)
    snakemake(run, "results/visemes/synthetic/visemes.tsv", "--forcerun", "visemes")
    snakemake(run, "results/flows/synthetic/bergen/bridge", "--forcerun", "flows")
    after = digest(sorted((results / "visemes/synthetic").rglob("*.*")))
    after |= digest(sorted((results / "flows/synthetic/bergen/bridge").glob("*.exr")))
    assert after == before


def test_killed_run_is_redone(tmp_path: Path) -> None:
    shutil.copy(ROOT / ".test" / "config.yaml", tmp_path / "config.yaml")
    proc = subprocess.Popen(
        [str(SNAKEMAKE), "--snakefile", str(ROOT / "Snakefile"), "--directory", str(tmp_path),
         "--cores", "1", "results/corpus/synthetic/corpus.mp4"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )  # fmt: skip
    frames = tmp_path / "results/corpus/synthetic/frames"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list(frames.glob("*.png"))) < 20:
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = len(list(frames.glob("*.png")))
    assert 0 < partial
    assert not (tmp_path / "results/corpus/synthetic/corpus.mp4").exists()
    # a hard kill leaves Snakemake's lock behind; its message tells the user to unlock
    assert (
        "--unlock" in snakemake(tmp_path, "results/corpus/synthetic/corpus.mp4", check=False).stderr
    )
    snakemake(tmp_path, "--unlock")
    snakemake(tmp_path, "results/corpus/synthetic/corpus.mp4")
    table = pd.read_csv(tmp_path / "results/corpus/synthetic/frames.tsv", sep="\t")
    assert len(list(frames.glob("*.png"))) == len(table) > partial


def test_a_persons_video_takes_the_corpus_place(run: Path, tmp_path: Path) -> None:
    """The synthetic corpus's own mp4, fed in as if it were a person's recording."""
    import yaml

    config = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())
    words = config["faces"]["synthetic"]["corpus"]["words"]
    video = str(run / "results/corpus/synthetic/corpus.mp4")
    config["faces"] = {"person": {"corpus": {"source": "video", "video": video, "words": words}}}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    snakemake(tmp_path)
    results = tmp_path / "results"
    assert (results / "utterances/person/hello.mp4").stat().st_size > 0
    assert "no\nground truth" in (results / "metrics/SKIPPED.txt").read_text()
    assert not (results / "metrics/flow_epe.csv").exists()
    # extraction from the decoded video still finds the synthetic face's true frames
    found = pd.read_csv(results / "visemes/person/targets.tsv", sep="\t")
    truth = pd.read_csv(run / "results/corpus/synthetic/truth.tsv", sep="\t")
    both = found.merge(truth, on="key", suffixes=("", "_true"))
    assert len(both) == len(truth)
    assert (both["frame"] - both["frame_true"]).abs().max() <= 1


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium not installed")
def test_report_renders_in_headless_chromium(run: Path) -> None:
    import cv2

    report = run / "report.html"
    proc = snakemake(run, "--report", str(report))
    assert report.stat().st_size > 10_000, proc.stderr[-2000:]
    html = report.read_text(errors="replace")
    for caption in ("Every corpus target", "Morph fidelity", "paper's Figure 8"):
        assert caption in html
    # the description names the config's faces, and no caption breaks docutils
    assert re.search(r"Faces: <tt[^>]*>synthetic, s1\b", html.replace("\\", ""))
    assert "(WARNING/" not in proc.stderr and "(ERROR/" not in proc.stderr
    shot = run / "report.png"
    subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={run / 'chromium-profile'}",
         "--window-size=1280,900", "--virtual-time-budget=5000",
         f"--screenshot={shot}", report.as_uri()],
        capture_output=True, timeout=120, check=True,
    )  # fmt: skip
    image = cv2.imread(str(shot))
    assert image is not None and image.shape[:2] == (900, 1280)
    # a rendered page, not a blank one: many distinct colours and real contrast
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 50
    assert image.std() > 20
