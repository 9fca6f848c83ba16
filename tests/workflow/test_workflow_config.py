"""The workflow's config checked before any job: small broken variants of the .test config
fail a dry run with one message naming the face and the clip; the clips' files are inputs
of the rules that read them."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = Path(sys.executable).parent / "snakemake"
DATA = ROOT / "data/grid_s1"


def dry_run(workdir: Path, config: dict) -> subprocess.CompletedProcess:
    (workdir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return subprocess.run(
        [str(SNAKEMAKE), "--snakefile", str(ROOT / "Snakefile"), "--directory", str(workdir),
         "--cores", "2", "--dry-run"],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip


def dot_test_config() -> dict:
    return yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())


def broken(change: dict) -> dict:
    """The .test config with s1's corpus settings changed."""
    config = dot_test_config()
    config["faces"]["s1"]["corpus"] |= change
    return config


TRAIN = dot_test_config()["faces"]["s1"]["corpus"]["train"]  # bbaf2n lgwg2n pric4p swih9a
TEST = dot_test_config()["faces"]["s1"]["corpus"]["test"]  # bbas3a srau3s


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"test": [*TEST, TRAIN[1]]},
            f"faces.s1.corpus: clip {TRAIN[1]} is in both train and test",
        ),
        ({"train": []}, "config: faces.s1.corpus.train: [] should be non-empty"),
        ({"train": [*TRAIN, TRAIN[0]]}, f"config: faces.s1.corpus.train: {TRAIN[0]} listed twice"),
        ({"test": [TEST[0], TEST[0]]}, f"config: faces.s1.corpus.test: {TEST[0]} listed twice"),
        (
            {"train": [*TRAIN, "zzzz9z"]},
            f"faces.s1.corpus: clip zzzz9z (train) is not in the transcript table "
            f"{DATA}/transcripts.txt",
        ),
        (
            {"media": "data/grid_s1/videos/{id}.mp4"},
            f"faces.s1.corpus: clip {TRAIN[0]} (train): media file not found: "
            f"{DATA}/videos/{TRAIN[0]}.mp4",
        ),
        (
            {"timings": "data/grid_s1/align/{id}.TextGrid"},
            f"faces.s1.corpus: clip {TRAIN[0]} (train): word timing file not found: "
            f"{DATA}/align/{TRAIN[0]}.TextGrid",
        ),
        (
            {"transcripts": "data/grid_s1/transcript.txt"},
            f"faces.s1.corpus: transcript table not found: {DATA}/transcript.txt",
        ),
        ({"media": None}, "faces.s1.corpus: a face from clips needs media"),
    ],
    ids=["overlap", "empty-train", "repeated-train", "repeated-test", "unknown-id",
         "missing-media", "missing-timings", "missing-table", "no-media"],
)  # fmt: skip
def test_broken_config_fails_the_dry_run(tmp_path: Path, change: dict, message: str) -> None:
    proc = dry_run(tmp_path, broken(change))
    assert proc.returncode != 0
    output = proc.stdout + proc.stderr  # (snakemake logs to stdout when it is not a terminal)
    assert any(line.startswith(message) for line in output.splitlines()), output
    assert "Job stats" not in output  # nothing was planned
    assert not (tmp_path / "results").exists()


def test_one_missing_test_clip_is_named(tmp_path: Path) -> None:
    """A held-out clip's missing media: the face, the clip and where it was looked for."""
    work = tmp_path / "work"
    work.mkdir()
    media = tmp_path / "media"
    media.mkdir()
    for clip in [*TRAIN, TEST[0]]:  # every clip's video but the second test clip's
        (media / f"{clip}.mpg").symlink_to(DATA / "video" / f"{clip}.mpg")
    proc = dry_run(work, broken({"media": f"{media}/{{id}}.mpg"}))
    assert proc.returncode != 0
    output = proc.stdout + proc.stderr
    problems = [line for line in output.splitlines() if line.startswith("faces.")]
    assert problems == [
        f"faces.s1.corpus: clip {TEST[1]} (test): media file not found: {media}/{TEST[1]}.mpg"
    ]


def test_snakemake_reads_the_projects_default_profile(tmp_path: Path) -> None:
    """profiles/default (the greedy scheduler) is read with no option, wherever it runs from."""
    proc = dry_run(tmp_path, dot_test_config())
    assert proc.returncode == 0, proc.stderr[-2000:]
    said = proc.stdout + proc.stderr
    used = re.search(r"Using workflow specific profile (\S+) for setting", said)
    assert used and Path(used[1]).resolve() == ROOT / "profiles" / "default"
    profile = yaml.safe_load((ROOT / "profiles" / "default" / "config.yaml").read_text())
    assert profile == {"scheduler": "greedy"}


def test_clip_files_are_inputs_of_the_rules_that_read_them(tmp_path: Path) -> None:
    """Training clips' files are inputs of corpus_clips, held-out clips' of heldout only."""
    proc = dry_run(tmp_path, dot_test_config())
    assert proc.returncode == 0, proc.stderr
    inputs = {}
    for block in re.split(r"\n(?=rule \w+:)", proc.stdout):
        if match := re.match(r"rule (\w+):", block):
            for line in block.splitlines():  # (a rule without inputs has no such line)
                if line.strip().startswith("input:"):
                    inputs[match[1]] = set(line.split(":", 1)[1].replace(",", " ").split())

    def files(clips: list[str]) -> set[str]:
        return {f"{DATA}/video/{c}.mpg" for c in clips} | {f"{DATA}/align/{c}.align" for c in clips}

    table = f"{DATA}/transcripts.txt"
    assert files(TRAIN) | {table} <= inputs["corpus_clips"]
    assert not files(TEST) & inputs["corpus_clips"]  # held out: never read to build the model
    assert files(TEST) | {table} <= inputs["heldout"]
    assert not files(TRAIN) & inputs["heldout"]


def test_training_clips_sweep_beyond_the_training_clips_takes_the_others_never_a_test_clip(
    tmp_path: Path,
) -> None:
    """sweeps.training_clips: N under the face's training clips takes its first N; N over them
    takes all of them, then the transcript table's other clips in name order, never a test clip;
    more than the table has is refused in one line."""
    config = dot_test_config()
    n = len(TRAIN) + 2
    config["sweeps"]["training_clips"] = [2, n]
    proc = dry_run(tmp_path, config)
    assert proc.returncode == 0, proc.stderr
    read = {}
    for block in re.split(r"\n(?=rule \w+:)", proc.stdout):
        face = re.search(r"wildcards: face=(\S+)", block)
        if block.startswith("rule corpus_clips:") and face:
            line = next(ln for ln in block.splitlines() if ln.strip().startswith("input:"))
            read[face[1]] = set(re.findall(r"video/(\w+)\.mpg", line))
    table = [ln.split()[0] for ln in (DATA / "transcripts.txt").read_text().splitlines()]
    others = sorted(set(table) - set(TRAIN) - set(TEST))
    assert read["s1-n2"] == set(TRAIN[:2])
    assert read[f"s1-n{n}"] == set(TRAIN) | set(others[:2])
    assert not set(TEST) & read[f"s1-n{n}"]
    config["sweeps"]["training_clips"] = [len(table)]
    proc = dry_run(tmp_path, config)
    assert proc.returncode != 0
    assert (
        f"only {len(table) - len(TEST)} clips that are not test clips" in proc.stdout + proc.stderr
    )


JOINED = "data/grid_s1/video/bbaf2n.mpg"  # any video: a dry run does not read it


@pytest.mark.parametrize(
    ("corpus", "message"),
    [
        (
            {"media": JOINED, "transcript": "data/grid_s1/transcripts.txt",
             "subtitles": "data/grid_s1/transcripts.txt"},
            "config: faces.v.corpus: source video takes video (a recording of the corpus "
            "words), or media with its transcript or its subtitles (one of the two)",
        ),
        ({"media": JOINED}, "config: faces.v.corpus: source video takes video"),
        (
            {"media": "data/grid_s1/video/nothere.mp4",
             "transcript": "data/grid_s1/transcripts.txt"},
            f"faces.v.corpus.media: file not found: {DATA}/video/nothere.mp4",
        ),
        (
            {"media": JOINED, "subtitles": "data/grid_s1/transcripts.txt"},
            f"faces.v.corpus.subtitles must be .srt or .vtt: {DATA}/transcripts.txt",
        ),
        (
            {"media": JOINED, "transcript": "data/grid_s1/transcripts.txt", "train": ["bbaf2n"]},
            "faces.v.corpus.train: not for a face from one video",
        ),
        (
            {"media": JOINED, "transcript": "data/grid_s1/transcripts.txt", "heldout_seconds": -1},
            "config: faces.v.corpus.heldout_seconds: -1 is less than the minimum of 0",
        ),
    ],
    ids=["both-scripts", "no-script", "missing-media", "not-subtitles", "train-listed",
         "negative-heldout"],
)  # fmt: skip
def test_broken_video_face_fails_the_dry_run(tmp_path: Path, corpus: dict, message: str) -> None:
    config = dot_test_config()
    config["faces"] = {"v": {"corpus": {"source": "video", **corpus}}}
    proc = dry_run(tmp_path, config)
    assert proc.returncode != 0
    assert message in proc.stdout + proc.stderr, proc.stdout[-2000:]


def test_a_video_face_plans_its_utterances_first(tmp_path: Path) -> None:
    config = dot_test_config()
    corpus = {"source": "video", "media": JOINED, "transcript": "data/grid_s1/transcripts.txt",
              "heldout_seconds": 1}  # fmt: skip
    config["faces"] = {"v": {"corpus": corpus}}
    proc = dry_run(tmp_path, config)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for rule in ("segment_video", "corpus_clips", "heldout", "dub_heldout"):
        assert f"rule {rule}:" in proc.stdout
    assert "results/segments/v.json" in proc.stdout


def test_a_face_in_its_face_crop_plans_its_corpus_to_its_held_out_dub(tmp_path: Path) -> None:
    """frame crop: the same rules as in the video's own pixels, the held-out dub included
    (through the product's dub path), which reads its clips back against the corpus's
    reference."""
    config = dot_test_config()
    config["faces"]["s1"] |= {"frame": "crop", "crop_size": 192}
    proc = dry_run(tmp_path, config)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    for rule in ("corpus_clips", "visemes_clips", "flows", "model", "utterance", "heldout",
                 "figure_heldout", "dub_heldout"):  # fmt: skip
        assert f"rule {rule}:" in proc.stdout, rule
    assert "results/metrics/dub/s1/summary.csv" in proc.stdout


@pytest.mark.parametrize(
    ("lipsync", "message"),
    [
        (
            {"model": "learned", "trajectory": "window"},
            "faces.s1: lipsync trajectory goes with lipsync model trained",
        ),
        ({"model": "trained", "trajectory": "heard"}, "'heard' is not one of"),
    ],
    ids=["not-trained", "heard-for-typed-text"],
)
def test_a_trajectory_goes_with_the_trained_face_and_typed_text(
    tmp_path: Path, lipsync: dict, message: str
) -> None:
    config = dot_test_config()
    config["faces"]["s1"]["lipsync"] = lipsync
    proc = dry_run(tmp_path, config)
    assert proc.returncode != 0
    assert message in proc.stdout + proc.stderr, proc.stdout[-2000:]
    assert not (tmp_path / "results").exists()


def test_a_recording_model_needs_a_face_from_clips(tmp_path: Path) -> None:
    config = dot_test_config()
    config["faces"]["synthetic"]["lipsync"] = {"recording_model": "trained"}
    proc = dry_run(tmp_path, config)
    assert proc.returncode != 0
    message = "faces.synthetic: lipsync recording_model 'trained' needs a face built from clips"
    assert message in proc.stdout + proc.stderr, proc.stdout[-2000:]
    assert not (tmp_path / "results").exists()


def test_the_sampling_strip_of_a_face_that_does_not_morph_like_the_paper_is_the_papers(
    tmp_path: Path,
) -> None:
    """Without a synthetic face the figures are drawn from s1, whose model is learned: the
    sampling strip's utterances are sweep utterances of the paper's model in every mode, not
    its own utterance at the configured point (which the strip refuses)."""
    config = dot_test_config()
    del config["faces"]["synthetic"]
    proc = dry_run(tmp_path, config)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for sampling in config["sweeps"]["sampling"]:
        assert f"results/utterances/s1/sweep/{sampling}/px2.5_fps30.json" in proc.stdout


@pytest.mark.parametrize(
    ("method", "message"),
    [
        ({"estimator": "bergen", "settings": {"levels": 0}}, "levels must be an integer >= 1"),
        ({"estimator": "bergen", "settings": {"levels": "five"}}, "got 'five'"),
        ({"estimator": "bergen", "settings": {"smooth": 2}}, "has no setting 'smooth'"),
        ({"estimator": "horn_schunck"}, "'horn_schunck' is not one of"),
    ],
)
def test_a_wrong_flow_setting_fails_the_dry_run(tmp_path: Path, method: dict, message: str) -> None:
    config = dot_test_config()
    config["flow"]["methods"]["bergen"] = method
    proc = dry_run(tmp_path, config)
    assert proc.returncode != 0
    assert message in proc.stdout + proc.stderr
