"""The workflow's settings module (miketalk_lab.workflow) on its own, without Snakemake: the
config's validation, the faces by kind, the sweeps, the path patterns, the rules' input
functions and the default target, on the .test config and config.yaml."""

from __future__ import annotations

import ast
import copy
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import LipsyncModel
from miketalk_lab.workflow import checks, paths, targets, vocabulary
from miketalk_lab.workflow.config import SCHEMA, ConfigError, canonical, validate_config
from miketalk_lab.workflow.experiment import Experiment
from miketalk_lab.workflow.inputs import CLIP_CHAIN, Inputs

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data/grid_s1"
_DOT_TEST = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())
_MAIN = yaml.safe_load((ROOT / "config.yaml").read_text())
TRAIN = _DOT_TEST["faces"]["s1"]["corpus"]["train"]  # bbaf2n lgwg2n pric4p swih9a
TEST = _DOT_TEST["faces"]["s1"]["corpus"]["test"]  # bbas3a srau3s
JOINED = "data/grid_s1/video/bbaf2n.mpg"  # any video: nothing here reads it
TRANSCRIPT = "data/grid_s1/transcripts.txt"


def dot_test() -> dict:
    """A fresh copy of the .test config (validation fills it in place)."""
    return copy.deepcopy(_DOT_TEST)


def experiment(config: dict | None = None) -> Experiment:
    return Experiment.from_config(dot_test() if config is None else config, ROOT)


def with_video_face(config: dict, **corpus: object) -> dict:
    """``config`` with a face ``v`` from one video of any speech, one second held out, in
    the video's own pixels."""
    config["faces"]["v"] = {
        "corpus": {"source": "video", "media": JOINED, "transcript": TRANSCRIPT,
                   "heldout_seconds": 1, **corpus},
        "frame": "full",
    }  # fmt: skip
    return config


def refused(config: dict) -> str:
    with pytest.raises(ConfigError) as caught:
        experiment(config)
    return str(caught.value)


# -- the config against its schema ---------------------------------------------------------


def test_validation_fills_in_the_schemas_defaults_like_snakemakes_validate() -> None:
    from snakemake.utils import validate

    for config in (dot_test(), copy.deepcopy(_MAIN), {}):
        ours, theirs = copy.deepcopy(config), copy.deepcopy(config)
        validate_config(ours, ROOT / SCHEMA)
        validate(theirs, str(ROOT / SCHEMA))
        assert ours == theirs
        assert list(ours) == list(theirs)  # (key order too: it orders the faces and methods)
    empty = validate_config({}, ROOT / SCHEMA)
    assert list(empty["faces"]) == ["synthetic"]
    assert empty["faces"]["synthetic"]["corpus"]["size"] == 256
    assert empty["flow"]["method"] == "bergen"


def s1_corpus(**change: object) -> dict:
    config = dot_test()
    config["faces"]["s1"]["corpus"] |= change
    return config


@pytest.mark.parametrize(
    ("config", "message"),
    [
        (s1_corpus(train=[]), "config: faces.s1.corpus.train: [] should be non-empty"),
        (s1_corpus(train=[*TRAIN, TRAIN[0]]),
         f"config: faces.s1.corpus.train: {TRAIN[0]} listed twice"),
        (s1_corpus(test=[TEST[1], TEST[0], TEST[1]]),
         f"config: faces.s1.corpus.test: {TEST[1]} listed twice"),
        (
            with_video_face(dot_test(), subtitles=TRANSCRIPT),
            "config: faces.v.corpus: source video takes video (a recording of the corpus "
            "words), or media with its transcript or its subtitles (one of the two)",
        ),
        (with_video_face(dot_test(), heldout_seconds=-1),
         "config: faces.v.corpus.heldout_seconds: -1 is less than the minimum of 0"),
        ({**dot_test(), "sweep": {}},
         "config: the config: Additional properties are not allowed ('sweep' was unexpected)"),
        ({**dot_test(), "lipsync": {"sampling": "smear"}},
         "config: lipsync.sampling: 'smear' is not one of ['blur', 'paper', 'none']"),
    ],
    ids=["empty-train", "repeated-train", "repeated-test", "both-scripts", "negative-heldout",
         "unknown-key", "unknown-sampling"],
)  # fmt: skip
def test_a_schema_violation_is_one_line_naming_the_key(config: dict, message: str) -> None:
    assert refused(config) == message


def test_the_vocabulary_is_the_librarys_as_plain_strings() -> None:
    """The models the checks and sweeps single out are the library's enums' values, plain
    strings: they go into params, whose repr must not change."""
    assert (vocabulary.PAPER, vocabulary.TRAINED) == (LipsyncModel.PAPER, LipsyncModel.TRAINED)
    assert vocabulary.FITTED_MODELS == (LipsyncModel.LEARNED, LipsyncModel.TRAINED)
    assert vocabulary.DIRECT in vocabulary.STRATEGY_NAMES
    for name in (vocabulary.PAPER, vocabulary.TRAINED, vocabulary.DIRECT, *vocabulary.SAMPLINGS):
        assert type(name) is str
    exp = experiment()
    assert "'model': 'paper'" in repr(exp.sweep_lipsync("s1", "blur"))


def test_canonical_sorts_every_mappings_keys_and_keeps_list_order() -> None:
    value = {"b": [{"z": 1, "a": 2}, 3], "a": {"y": None, "x": "s"}}
    out = canonical(value)
    assert repr(out) == "{'a': {'x': 's', 'y': None}, 'b': [{'a': 2, 'z': 1}, 3]}"
    assert out == value


# -- faces ---------------------------------------------------------------------------------


def test_faces_by_kind() -> None:
    config = with_video_face(dot_test())
    config["faces"]["recorded"] = {"corpus": {"source": "video", "video": JOINED}}
    config["sweeps"]["training_clips"] = [2, len(TRAIN) + 2]
    exp = experiment(config)
    n = len(TRAIN) + 2
    assert list(exp.faces) == ["synthetic", "s1", "v", "recorded", "s1-n2", f"s1-n{n}"]
    assert list(exp.configured) == ["synthetic", "s1", "v", "recorded"]
    assert exp.corpus_word_faces == ["synthetic", "recorded"]
    assert exp.video_faces == ["v"]
    assert exp.clip_faces == ["s1", "v", "s1-n2", f"s1-n{n}"]
    assert (exp.truth_face, exp.truth, exp.figure_face) == ("synthetic", "synthetic", "synthetic")
    assert exp.truth_size == 128
    assert [f for f in exp.faces if exp.has_test(f)] == ["s1", "v", "s1-n2", f"s1-n{n}"]
    assert (exp.first_test_clip("s1"), exp.first_test_clip("v")) == (TEST[0], None)


def test_without_a_synthetic_face_there_is_no_truth_and_the_figures_take_the_first() -> None:
    config = dot_test()
    del config["faces"]["synthetic"]
    exp = experiment(config)
    assert (exp.truth_face, exp.truth, exp.figure_face, exp.truth_size) == (
        None,
        "none",
        "s1",
        None,
    )
    assert exp.corpus_word_faces == []


def test_a_faces_settings_are_the_configs_with_its_own_overrides() -> None:
    exp = experiment(copy.deepcopy(_MAIN))
    s1 = exp.morph_options("s1")
    assert s1 == {
        "fill_holes": True,
        "hole_aware_blend": True,
        "median": False,
        "splat": "bilinear",
    }
    assert list(s1) == sorted(s1)
    assert exp.morph_options("synthetic")["median"] is True
    assert exp.morph_options("none") == canonical(exp.config["morph"])  # (no such face)
    assert (exp.lipsync_options("s1")["model"], exp.recording_model("s1")) == ("learned", "trained")
    assert exp.recording_model("synthetic") == "paper"  # no recording_model: its model
    assert exp.model_flow("s1") == ("bergen", "bridge")
    assert exp.model_flows("s1") == "results/flows/s1/bergen/bridge"
    corpus = exp.corpus_settings("s1")
    assert corpus["media"] == f"{DATA}/video/{{id}}.mpg"  # absolute, {id} kept
    assert corpus["transcripts"] == f"{DATA}/transcripts.txt"
    assert corpus["video"] is None
    assert list(corpus) == sorted(corpus)
    assert exp.face_background("s1") == "auto"
    assert exp.face_background("none") == "still"
    exp.faces["s1"]["background"] = JOINED
    assert exp.face_background("s1") == str(ROOT / JOINED)
    assert exp.grouping == {}


def test_a_faces_frame_is_its_videos_pixels_unless_its_crop_is_configured() -> None:
    from miketalk.building.frame import FrameSettings
    from miketalk.track.crop import FaceCropSettings, crop_from_doc

    exp = experiment()
    assert (
        exp.frame_settings("s1") == FrameSettings("full") and exp.frame_settings("s1").crop is None
    )
    # no crop key: the corpus rule's params are what they were before the setting existed
    assert exp.corpus_build_settings("s1") == exp.corpus_settings("s1")
    assert "crop" not in exp.corpus_build_settings("s1")
    config = dot_test()
    config["faces"]["s1"] |= {"frame": "crop"}
    assert experiment(config).frame_settings("s1").crop == FaceCropSettings()  # the crop's own
    config = dot_test()
    config["faces"]["s1"] |= {"frame": "crop", "crop_size": 192}
    config["sweeps"]["training_clips"] = [2]
    exp = experiment(config)
    crop = exp.frame_settings("s1").crop
    assert (crop.size, crop.eye_distance) == (192, 54.0)  # the eye distance in proportion
    built = exp.corpus_build_settings("s1")
    assert crop_from_doc(built.pop("crop")) == crop
    assert built == exp.corpus_settings("s1")
    assert exp.frame_settings("s1-n2").crop == crop  # the training-clips sweep's face too


def test_one_default_frame_for_the_command_line_and_the_workflow() -> None:
    """Issue 49: ``miketalk build`` defaulted to the crop, the workflow's schema to the
    video's own pixels. Now one constant: a face of a person (clips, one video) that names no
    frame is built in the crop, as ``miketalk build`` builds; the synthetic face and a
    recording of the corpus words have no other frame than their own pixels."""
    from miketalk.api import BuildSettings
    from miketalk.building.frame import CROP, DEFAULT_FRAME, FULL

    assert BuildSettings().frame == DEFAULT_FRAME == CROP
    config = with_video_face(dot_test())
    for face in ("s1", "v"):
        del config["faces"][face]["frame"]
    config["faces"]["recorded"] = {"corpus": {"source": "video", "video": JOINED}}
    config["sweeps"]["training_clips"] = [2]  # its face s1-n2 takes s1's frame
    exp = experiment(config)
    assert exp.faces["s1"]["frame"] is None  # the schema's default: the face's own
    for face in ("s1", "v", "s1-n2"):
        assert exp.frame_settings(face).frame == DEFAULT_FRAME, face
        assert exp.frame_settings(face).crop is not None
    for face in ("synthetic", "recorded"):
        assert exp.frame_settings(face).frame == FULL and exp.frame_settings(face).crop is None
    assert experiment(dot_test()).frame_settings("s1").frame == FULL  # named in .test's config


@pytest.mark.parametrize(
    ("face", "change", "problem"),
    [
        ("s1", {"crop_size": 192}, "faces.s1: crop_size goes with frame crop"),
        ("synthetic", {"frame": "crop"}, "faces.synthetic: frame crop needs a face from clips"),
        ("v", {"frame": "crop", "corpus": {"source": "video", "video": JOINED}},
         "faces.v: frame crop needs a face from clips or from one video of any speech"),
        ("s1", {"frame": "crop", "crop_size": 8},
         "config: faces.s1.crop_size: 8 is less than the minimum of 16"),
        ("s1", {"frame": "face"},
         "config: faces.s1.frame: 'face' is not one of ['crop', 'full', None]"),
    ],
    ids=["size-without-crop", "synthetic", "corpus-words-video", "too-small", "unknown"],
)  # fmt: skip
def test_a_faces_frame_is_checked_before_any_job(face: str, change: dict, problem: str) -> None:
    config = dot_test()
    config["faces"].setdefault(face, {}).update(change)
    assert refused(config).startswith(problem)


def test_a_crop_face_from_one_video_builds_in_its_crop_and_is_dubbed() -> None:
    config = with_video_face(dot_test())
    config["faces"]["v"]["frame"] = "crop"
    exp = experiment(config)
    assert exp.corpus_build_settings("v")["crop"]["size"] == 256
    wanted = targets.all_outputs(exp)
    assert paths.at(paths.HELDOUT_SUMMARY, "v") in wanted
    assert paths.at(paths.DUB_SUMMARY, "v") in wanted  # through the product's dub path
    assert paths.at(paths.DUB_SUMMARY, "s1") in wanted  # s1's own pixels: dubbed as before
    dub_inputs = Inputs(exp).crop_dub_inputs
    assert dub_inputs(SimpleNamespace(face="v")) == {
        "reference": paths.at(paths.CORPUS_REFERENCE, "v")
    }
    assert dub_inputs(SimpleNamespace(face="s1")) == {}  # a full face's inputs as they were


# -- checks --------------------------------------------------------------------------------


def test_a_trajectory_goes_with_the_trained_model() -> None:
    config = dot_test()
    config["faces"]["s1"]["lipsync"] = {"model": "learned", "trajectory": "window"}
    assert refused(config) == "faces.s1: lipsync trajectory goes with lipsync model trained"
    fine = ({"model": "trained", "trajectory": "window"}, {"model": "paper", "trajectory": None})
    for lipsync in fine:
        checks.check_lipsync("s1", lipsync, "trained", from_clips=True)
    with pytest.raises(ConfigError) as caught:
        checks.check_lipsync("s1", {"model": "paper", "trajectory": "window"}, "trained", True)
    assert str(caught.value) == "faces.s1: lipsync trajectory goes with lipsync model trained"


def test_a_model_fitted_to_clips_needs_a_face_from_clips() -> None:
    config = dot_test()
    config["faces"]["synthetic"]["lipsync"] = {"recording_model": "trained"}
    assert refused(config).startswith(
        "faces.synthetic: lipsync recording_model 'trained' needs a face built from clips"
    )
    config = with_video_face(dot_test())
    config["faces"]["v"]["lipsync"] = {"model": "trained"}
    experiment(config)  # one video of any speech: its utterances are clips


def test_a_faces_flow_method_is_configured_and_its_strategy_known() -> None:
    config = dot_test()
    config["faces"]["s1"]["flow"] = {"method": "farneback"}
    assert refused(config) == "faces.s1: flow method 'farneback' is not in flow.methods (bergen)"
    config["faces"]["s1"]["flow"] = {"strategy": "teleport"}
    assert refused(config).startswith("config: faces.s1.flow.strategy: 'teleport' is not one of")
    with pytest.raises(MiketalkError, match="unknown flow strategy 'teleport'"):
        checks.check_face_settings(
            "s1", lipsync={"model": "paper", "trajectory": None}, recording_model="paper",
            from_clips=True, method="bergen", strategy="teleport", methods={"bergen": {}},
        )  # fmt: skip


@pytest.mark.parametrize(
    ("settings", "problem"),
    [
        ({"levels": 0}, "levels must be an integer >= 1, got 0"),
        ({"levels": "five"}, "levels must be an integer >= 1, got 'five'"),
        ({"smooth": 2}, "flow estimator 'bergen' has no setting 'smooth'"),
    ],
)
def test_a_flow_methods_settings_are_checked_before_any_job(settings: dict, problem: str) -> None:
    config = dot_test()
    config["flow"]["methods"]["bergen"]["settings"] = settings
    assert refused(config).startswith(f"flow.methods.bergen: {problem}")


def test_an_unknown_estimator_is_refused_by_the_schema() -> None:
    config = dot_test()
    config["flow"]["methods"]["bergen"]["estimator"] = "horn_schunck"
    assert refused(config).startswith("config: flow.methods.bergen.estimator: 'horn_schunck'")


@pytest.mark.parametrize(
    ("change", "problems"),
    [
        ({"test": [*TEST, TRAIN[1]]},
         [f"faces.s1.corpus: clip {TRAIN[1]} is in both train and test (a held-out clip must "
          "never be read while building the model)"]),
        ({"train": [*TRAIN, "zzzz9z"]},
         ["faces.s1.corpus: clip zzzz9z (train) is not in the transcript table "
          f"{DATA}/transcripts.txt"]),
        ({"transcripts": "data/grid_s1/transcript.txt"},
         [f"faces.s1.corpus: transcript table not found: {DATA}/transcript.txt"]),
        ({"media": None}, ["faces.s1.corpus: a face from clips needs media"]),
        ({"timings": "data/grid_s1/align/x.align"},
         ["faces.s1.corpus.timings must contain {id}, got " f"'{DATA}/align/x.align'"]),
        ({"media": "data/grid_s1/videos/{id}.mp4"},
         [*[f"faces.s1.corpus: clip {c} ({split}): media file not found: {DATA}/videos/{c}.mp4"
            for split, clips in (("train", TRAIN), ("test", TEST)) for c in clips][:5],
          "... and 1 more"]),
    ],
    ids=["overlap", "unknown-id", "missing-table", "no-media", "timings-without-id",
         "six-missing-media"],
)  # fmt: skip
def test_a_clip_faces_problems_one_line_each_the_first_five(change: dict, problems: list) -> None:
    assert refused(s1_corpus(**change)).splitlines() == problems


def test_a_video_faces_problems() -> None:
    config = with_video_face(dot_test(), media="data/grid_s1/video/nothere.mp4", train=["bbaf2n"])
    assert refused(config).splitlines() == [
        f"faces.v.corpus.media: file not found: {DATA}/video/nothere.mp4",
        "faces.v.corpus.train: not for a face from one video (its utterances are found in it; "
        "heldout_seconds holds out its end)",
    ]
    config = with_video_face(dot_test(), transcript=None, subtitles=TRANSCRIPT)
    assert (
        refused(config) == f"faces.v.corpus.subtitles must be .srt or .vtt: {DATA}/transcripts.txt"
    )


# -- sweeps --------------------------------------------------------------------------------


def test_the_training_clips_sweep_takes_the_first_clips_then_others_never_a_test_clip() -> None:
    config = dot_test()
    n = len(TRAIN) + 2
    config["sweeps"]["training_clips"] = [2, n, len(TRAIN)]
    exp = experiment(config)
    table = [line.split()[0] for line in (DATA / "transcripts.txt").read_text().splitlines()]
    others = sorted(set(table) - set(TRAIN) - set(TEST))
    assert exp.faces["s1-n2"]["corpus"]["train"] == TRAIN[:2]
    assert exp.faces[f"s1-n{n}"]["corpus"]["train"] == [*TRAIN, *others[:2]]
    assert f"s1-n{len(TRAIN)}" not in exp.faces  # that is s1 itself
    assert exp.faces["s1-n2"]["corpus"]["test"] == TEST
    assert exp.sweep_of("s1") == {2: "s1-n2", n: f"s1-n{n}", len(TRAIN): "s1"}
    assert list(exp.sweep_of("s1"))[-1] == len(TRAIN)  # the face itself last
    assert exp.sweep_of("synthetic") == {}
    config = dot_test()
    config["sweeps"]["training_clips"] = [len(table)]
    assert refused(config) == (
        f"sweeps.training_clips: {len(table)} clips for faces.s1, but its transcript table "
        f"has only {len(table) - len(TEST)} clips that are not test clips"
    )


def test_the_pyramid_depth_sweep_adds_methods() -> None:
    exp = experiment(copy.deepcopy(_MAIN))
    assert list(exp.sweep_methods) == [f"{e}-L{n}" for e in ("bergen", "farneback")
                                       for n in range(1, 7)]  # fmt: skip
    assert exp.methods["bergen-L2"] == {"estimator": "bergen", "settings": {"levels": 2}}
    assert list(exp.methods)[:3] == ["bergen", "dis_medium", "farneback"]
    assert json.loads(exp.method_json("farneback-L3")) == {
        "estimator": "farneback", "settings": {"levels": 3}
    }  # fmt: skip
    assert exp.method_json("bergen") == '{"estimator": "bergen", "settings": {"levels": 5}}'


def test_the_sync_sweep_points_and_the_configured_one() -> None:
    exp = experiment(copy.deepcopy(_MAIN))
    points = exp.sync_sweep_points()
    assert len(points) == len(set(points)) == 2 * (4 + 3 - 1)  # (2.5, 30) once
    assert points == sorted(points)
    assert ("paper", 8.0, 30) in points and ("blur", 2.5, 60) in points
    assert exp.is_configured_point("synthetic", "blur", 2.5, 30)
    assert not exp.is_configured_point("synthetic", "paper", 2.5, 30)
    assert not exp.is_configured_point("s1", "blur", 2.5, 30)  # learned: not the paper's
    lipsync = exp.sweep_lipsync("s1", "paper")
    assert (lipsync["model"], lipsync["sampling"], lipsync["trajectory"]) == (
        "paper",
        "paper",
        None,
    )
    assert lipsync["recording_model"] == "trained" and list(lipsync) == sorted(lipsync)
    assert (
        exp.sweep_timeline("synthetic", "blur", 2.5, 30)
        == "results/utterances/synthetic/quick.json"
    )
    assert exp.sweep_timeline("s1", "blur", 2.5, 30) == (
        "results/utterances/s1/sweep/blur/px2.5_fps30.json"
    )
    exp.config["lipsync"]["max_px_per_frame"] = None  # no limit: no fps to sweep at
    assert {px for _, px, _ in exp.sync_sweep_points()} == {1.5, 2.5, 4.0, 8.0}
    assert exp.strip_max_px() == defaults.MAX_PX_PER_FRAME


# -- paths ---------------------------------------------------------------------------------

WILDCARDS = {"face", "method", "strategy", "sentence", "sampling", "px", "fps"}
PATTERNS = {
    name: value
    for name, value in vars(paths).items()
    if name.isupper() and isinstance(value, str) and name not in ("NUMBER", "SWEEP_POINT")
}


def test_every_path_pattern_is_under_results_with_known_wildcards() -> None:
    assert len(PATTERNS) > 60
    for name, pattern in PATTERNS.items():
        assert pattern == "results" or pattern.startswith("results/"), name
        assert set(re.findall(r"\{(\w+)\}", pattern)) <= WILDCARDS, name
    assert len(set(PATTERNS.values())) == len(PATTERNS)  # no file named twice


def test_the_per_face_folders_are_the_librarys() -> None:
    for pattern, folder in [
        (paths.CORPUS, defaults.corpus_dir), (paths.VISEMES, defaults.visemes_dir),
        (paths.FLOWS, defaults.flows_dir), (paths.MODEL, defaults.model_dir),
        (paths.TRUTH, defaults.truth_dir),
    ]:  # fmt: skip
        assert Path(paths.at(pattern, "s1")) == folder("s1")
    assert Path(paths.METRICS) == defaults.metrics_dir()
    assert Path(paths.FIGURES) == defaults.figures_dir()


def test_filling_in_wildcards() -> None:
    assert (
        paths.fill(paths.SYNC, face="synthetic") == "results/metrics/sync/synthetic/{sentence}.csv"
    )
    assert paths.fill(paths.SYNC_SWEEP, face="f", sampling="blur", px=2.5, fps=30) == (
        "results/metrics/sync_sweep/f/blur/px2.5_fps30.csv"
    )
    assert paths.at(paths.FLOW_CHOICES, "s1") == "results/flows/s1/{method}/{strategy}.tsv"
    assert paths.log("flows/{face}/{method}") == "results/logs/flows/{face}/{method}.log"
    assert (
        paths.benchmark("sync/{face}", face="synthetic") == "results/benchmarks/sync/synthetic.tsv"
    )


def test_one_of_matches_exactly_the_names() -> None:
    constraint = paths.one_of(["s1", "s1-n2", "a.b"])
    assert [bool(re.fullmatch(constraint, n)) for n in ("s1", "s1-n2", "a.b", "axb", "s")] == [
        True, True, True, False, False
    ]  # fmt: skip
    assert re.fullmatch(paths.one_of([]), "") is None
    assert re.fullmatch(paths.NUMBER, "2.5") and not re.fullmatch(paths.NUMBER, "2.")


def test_the_rules_spell_no_path_and_common_smk_holds_no_logic() -> None:
    """Every path the rules use is a pattern of paths.py; common.smk only builds the
    experiment."""
    rules = [ROOT / "Snakefile", *sorted((ROOT / "workflow" / "rules").glob("*.smk"))]
    for path in rules:
        text = path.read_text()
        assert "results/" not in text, path.name
        assert not re.search(r"^\s*def |^\s*class |^\s*(for|if|while) ", text, re.M), path.name
    assert len((ROOT / "workflow" / "rules" / "common.smk").read_text().splitlines()) < 30


def test_the_module_does_not_use_snakemake() -> None:
    for path in (ROOT / "src" / "miketalk_lab" / "workflow").glob("*.py"):
        tree = ast.parse(path.read_text())
        names = [
            alias.name for n in ast.walk(tree) if isinstance(n, ast.Import) for alias in n.names
        ]
        names += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        assert not [n for n in names if n.split(".")[0] == "snakemake"], path.name


# -- input functions -----------------------------------------------------------------------


def wildcards(**values: str) -> SimpleNamespace:
    return SimpleNamespace(**values)


def test_the_clips_files_are_inputs_of_their_split_only() -> None:
    inputs = Inputs(experiment())
    train = inputs.clip_inputs("train")(wildcards(face="s1"))
    test = inputs.clip_inputs("test")(wildcards(face="s1"))
    assert train == {
        "transcripts": f"{DATA}/transcripts.txt",
        "media": [f"{DATA}/video/{c}.mpg" for c in TRAIN],
        "timings": [f"{DATA}/align/{c}.align" for c in TRAIN],
    }
    assert test["media"] == [f"{DATA}/video/{c}.mpg" for c in TEST]
    assert test["timings"] == [f"{DATA}/align/{c}.align" for c in TEST]


def test_a_video_faces_inputs_are_its_video_and_its_utterances() -> None:
    inputs = Inputs(experiment(with_video_face(dot_test())))
    v = wildcards(face="v")
    assert inputs.clip_inputs("train")(v) == {
        "media": str(ROOT / JOINED), "segments": "results/segments/v.json"
    }  # fmt: skip
    assert inputs.video_script(v) == {
        "media": str(ROOT / JOINED),
        "transcript": str(ROOT / TRANSCRIPT),
    }
    assert inputs.clip_corpus(v) == {
        "phones": "results/corpus/v/phones.tsv",
        "regions": "results/corpus/v/regions.json",
        "eigenlips": "results/corpus/v/eigenlips.npz",
        "segments": "results/segments/v.json",
    }


def test_the_flow_and_model_inputs() -> None:
    inputs = Inputs(experiment())
    bridge = wildcards(face="s1", method="bergen", strategy="bridge")
    assert inputs.mixed_flows(bridge) == {"mixed": "results/flows/s1/bergen/mixed"}
    assert inputs.mixed_flows(wildcards(face="s1", method="bergen", strategy="direct")) == {}
    assert inputs.clip_regions(bridge) == {"regions": "results/corpus/s1/regions.json"}
    assert inputs.clip_regions(wildcards(face="synthetic")) == {}
    assert set(inputs.clip_corpus(wildcards(face="s1"))) == {"phones", "regions", "eigenlips"}
    assert inputs.clip_corpus(wildcards(face="synthetic")) == {}
    assert (
        inputs.model_flows(wildcards(face="synthetic")) == "results/flows/synthetic/bergen/bridge"
    )
    assert inputs.method_spec(wildcards(method="bergen-L1")) == (
        '{"estimator": "bergen", "settings": {"levels": 1}}'
    )
    assert inputs.clip_chain_first(wildcards(face="s1")) == CLIP_CHAIN == inputs.CLIP_CHAIN
    assert inputs.clip_chain_first(wildcards(face="synthetic")) == 0


def test_a_heldout_evaluation_measures_the_faces_model_and_the_configured_variants() -> None:
    config = dot_test()
    config["sweeps"]["training_clips"] = [2]
    config["evaluation"]["models"] = ["bergen/direct", "bergen/bridge"]
    inputs = Inputs(experiment(config))
    assert inputs.heldout_models(wildcards(face="s1")) == {
        "model:bergen/bridge": "results/model/s1",  # its own, once
        "model:bergen/direct": "results/model_variants/s1/bergen/direct",
    }
    assert inputs.heldout_models(wildcards(face="s1-n2")) == {
        "model:bergen/bridge": "results/model/s1-n2"
    }
    assert inputs.training_clip_summaries(wildcards(face="s1")) == [
        "results/metrics/heldout/s1-n2/summary.csv",
        "results/metrics/heldout/s1/summary.csv",
    ]


# -- targets -------------------------------------------------------------------------------


def test_the_default_target_of_the_test_config() -> None:
    exp = experiment()
    out = targets.all_outputs(exp)
    assert len(out) == len(set(out))
    for face in ("synthetic", "s1"):
        assert f"results/visemes/{face}/contact_sheet.png" in out
        assert f"results/model/{face}" in out
        assert f"results/utterances/{face}/hello.mp4" in out
    assert targets.heldout_tables(exp) == [
        "results/metrics/heldout/s1/summary.csv",
        "results/figures/heldout/s1/trajectory.png",
        "results/figures/heldout/s1/psnr.png",
        "results/figures/heldout/s1/strip.png",
        "results/metrics/dub/s1/summary.csv",
        "results/figures/dub/s1/strip.png",
    ]
    assert set(targets.heldout_tables(exp)) < set(out)
    assert {"results/metrics/flow_epe.csv", "results/metrics/sync_sweep.csv"} < set(out)
    assert "results/metrics/SKIPPED.txt" not in out
    assert "results/metrics/motorcycle_epe.csv" not in out  # metrics.motorcycle: false
    assert targets.epe_tables(exp) == [
        *(f"results/metrics/epe/synthetic/bergen/{s}.csv"
          for s in ("direct", "concat", "mixed", "bridge")),
        "results/metrics/epe/synthetic/bergen-L1/direct.csv",
        "results/metrics/epe/synthetic/bergen-L3/direct.csv",
    ]  # fmt: skip
    assert targets.sync_tables(exp) == ["results/metrics/sync/synthetic/hello.csv"]
    assert targets.sync_sweep_tables(exp) == [
        "results/metrics/sync/synthetic/hello.csv",  # the configured point: the sync rule's
        "results/metrics/sync_sweep/synthetic/paper/px2.5_fps30.csv",
    ]
    assert targets.sampling_strip_timelines(exp) == [
        "results/utterances/synthetic/hello.json",
        "results/utterances/synthetic/sweep/paper/px2.5_fps30.json",
    ]


def test_without_truth_the_default_target_notes_it_and_the_strip_takes_sweep_utterances() -> None:
    config = dot_test()
    del config["faces"]["synthetic"]
    exp = experiment(config)
    out = targets.all_outputs(exp)
    assert "results/metrics/SKIPPED.txt" in out
    assert not [
        f for f in out if f.startswith(("results/metrics/flow_epe", "results/metrics/sync"))
    ]
    assert targets.epe_tables(exp) == []
    assert targets.sampling_strip_timelines(exp) == [
        f"results/utterances/s1/sweep/{s}/px2.5_fps30.json" for s in ("blur", "paper")
    ]


def test_the_default_target_of_config_yaml() -> None:
    exp = experiment(copy.deepcopy(_MAIN))
    out = targets.all_outputs(exp)
    assert len(targets.epe_tables(exp)) == 3 * 4 + 2 * 6
    assert len(targets.utterance_videos(exp)) == 2 * 3
    assert "results/metrics/motorcycle_epe.csv" in out
    assert out[-1] == "results/metrics/motorcycle_epe.csv"
    assert out[:4] == [
        "results/visemes/synthetic/contact_sheet.png",
        "results/visemes/s1/contact_sheet.png",
        "results/model/synthetic",
        "results/model/s1",
    ]
