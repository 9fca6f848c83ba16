"""``miketalk build``: a model from one video (s1's clips joined at test time), then say and dub.

The video is four of the committed GRID s1 clips joined (12 s), its last 3 s
held out; the model it makes must be one that ``say``, ``say --audio`` and
``dub`` take. Bad input is one line, exit status 2, and nothing written.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from miketalk import cli, defaults
from miketalk.bench.joined import join_clips
from miketalk.speech import FestivalBackend

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "grid_s1"
CLIPS = ["bbaf2n", "lgwg2n", "pric4p", "swih9a", "bbas3a"]

needs_festival = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival not installed"
)


def test_the_build_flows_are_the_workflows_defaults() -> None:
    schema = yaml.safe_load((ROOT / "workflow/schemas/config.schema.yaml").read_text())
    flow = schema["properties"]["flow"]["properties"]
    assert flow["methods"]["default"]["bergen"] == defaults.BUILD_FLOW_METHOD
    assert flow["strategy"]["default"] == defaults.BUILD_FLOW_STRATEGY
    assert flow["mixed_window"]["default"] == defaults.BUILD_MIXED_WINDOW


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def joined(tmp_path_factory: pytest.TempPathFactory):
    return join_clips(
        CLIPS,
        tmp_path_factory.mktemp("joined"),
        media=str(DATA / "video" / "{id}.mpg"),
        transcripts=DATA / "transcripts.txt",
        timings=str(DATA / "align" / "{id}.align"),
    )


@pytest.fixture(scope="module")
def built(joined, tmp_path_factory: pytest.TempPathFactory) -> Path:
    model = tmp_path_factory.mktemp("build") / "model"
    code = cli.main(
        ["build", str(joined.video), "--transcript", str(joined.transcript), "-o", str(model),
         "--heldout-seconds", "3", "--quiet"]
    )  # fmt: skip
    assert code == 0
    return model


@pytest.mark.slow
def test_build_writes_a_model_of_the_training_part(built: Path) -> None:
    manifest = json.loads((built / "manifest.json").read_text())
    assert manifest["size"] == [288, 360]
    segments = json.loads((built / "build" / "segments.json").read_text())
    splits = [u["split"] for u in segments["utterances"]]
    assert splits == ["train"] * 4 + ["test"]
    assert (built / "background").is_dir() and (built / "coarticulation.json").is_file()
    assert not list(built.parent.glob(".model.build-*"))  # the work folder is gone


@pytest.mark.slow
@needs_festival
def test_say_and_dub_take_the_built_model(
    built: Path, joined, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = _run(
        capsys,
        "say",
        "Bin blue at F two now.",
        "--model",
        str(built),
        "-o",
        str(tmp_path / "a.mp4"),
    )
    assert code == 0, err
    code, _, err = _run(
        capsys, "say", "--audio", str(DATA / "video" / "bbas3a.mpg"), "--text",
        "bin blue at s three again", "--model", str(built), "--lipsync-model", "learned",
        "-o", str(tmp_path / "b.mp4"),
    )  # fmt: skip
    assert code == 0, err
    code, _, err = _run(
        capsys, "dub", str(DATA / "video" / "srau3s.mpg"), "--text", "Hello world.",
        "--model", str(built), "-o", str(tmp_path / "c.mp4"),
    )  # fmt: skip
    assert code == 0, err
    assert all((tmp_path / f"{n}.mp4").stat().st_size > 0 for n in "abc")


@pytest.mark.slow
def test_an_existing_model_needs_force(
    built: Path, joined, capsys: pytest.CaptureFixture[str]
) -> None:
    before = (built / "manifest.json").read_bytes()
    code, _, err = _run(
        capsys, "build", str(joined.video), "--transcript", str(joined.transcript), "-o", str(built)
    )
    assert code == 2 and err.count("\n") == 1 and "--force" in err
    assert (built / "manifest.json").read_bytes() == before


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["nothere.mp4", "--transcript", "{transcript}"], "video not found"),
        (["{video}", "--transcript", "{french}"], "another language"),
        (["{video}"], "--transcript or its --subtitles"),
        (["{video}", "--subtitles", "{transcript}"], "must be .srt or .vtt"),
        (["{video}", "--transcript", "{transcript}", "--heldout-seconds", "60"], "holds out all"),
    ],
    ids=["no-video", "french", "no-script", "not-subtitles", "all-held-out"],
)
def test_bad_input_is_one_line_and_nothing_written(
    joined, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    french = tmp_path / "fr.txt"
    french.write_text("Le chat est sur la table et il ne dort pas. Nous avons une maison.")
    names = {"video": joined.video, "transcript": joined.transcript, "french": french}
    model = tmp_path / "out" / "model"
    code, _, err = _run(
        capsys, "build", *[a.format(**names) for a in args], "-o", str(model), "--quiet"
    )
    assert code == 2, err
    assert err.count("\n") == 1 and message in err, err
    assert not model.exists() and not list((tmp_path / "out").glob(".*"))
