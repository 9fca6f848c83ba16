"""Each closed vocabulary is spelled once, in the library; the workflow's config schema and the
command line agree with it, and so do their defaults.

The vocabularies: lip-sync models, trajectories and samplings
(:mod:`miketalk.lipsync.settings`), flow estimators (:mod:`miketalk.flow.registry`) and flow
strategies (:mod:`miketalk.flow.strategies`), voices (:mod:`miketalk.speech.festival.voices`).
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

import pytest
import yaml

from miketalk import defaults
from miketalk.flow.registry import ESTIMATORS
from miketalk.flow.strategies import STRATEGY_NAMES
from miketalk.lipsync.settings import (
    LIPSYNC_MODELS,
    SAMPLINGS,
    TRAJECTORIES,
    LipsyncModel,
    LipsyncSettings,
    Sampling,
    Trajectory,
)
from miketalk.speech.festival.voices import VOICES

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = yaml.safe_load((ROOT / "workflow" / "schemas" / "config.schema.yaml").read_text())


def _schema(*path: str) -> dict:
    node = SCHEMA
    for key in path:
        node = node["properties"][key] if "properties" in node else node[key]
    return node


def _choices(parser: argparse.ArgumentParser, command: str, option: str) -> argparse.Action:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return next(a for a in sub.choices[command]._actions if option in a.option_strings)


@pytest.fixture(scope="module")
def parser() -> argparse.ArgumentParser:
    from miketalk.cli.parser import build_parser

    return build_parser()


def test_the_enums_are_the_vocabularies() -> None:
    assert LIPSYNC_MODELS == ("paper", "learned", "trained") == tuple(LipsyncModel)
    assert SAMPLINGS == ("blur", "paper", "none") == tuple(Sampling)
    assert TRAJECTORIES == ("window", "regularized", "heard", "pooled") == tuple(Trajectory)


def test_schema_lipsync_vocabularies_are_the_library_s() -> None:
    recorded = (Trajectory.HEARD, Trajectory.POOLED)  # a recording only
    typed = [t for t in TRAJECTORIES if t not in recorded]
    face = _schema("faces")["additionalProperties"]["properties"]
    for props in (_schema("lipsync")["properties"], face["lipsync"]["properties"]):
        assert [m for m in props["model"]["enum"] if m is not None] == list(LIPSYNC_MODELS)
        assert props["recording_model"]["enum"] == [*LIPSYNC_MODELS, None]
        assert props["trajectory"]["enum"] == [*typed, None]
    assert _schema("lipsync", "sampling")["enum"] == list(SAMPLINGS)
    assert set(_schema("sweeps", "sampling")["items"]["enum"]) <= set(SAMPLINGS)


def test_schema_defaults_are_the_library_s() -> None:
    settings = LipsyncSettings()
    assert _schema("lipsync", "fps")["default"] == settings.fps == defaults.FPS
    assert _schema("lipsync", "max_px_per_frame")["default"] == settings.max_px_per_frame
    assert _schema("lipsync", "sampling")["default"] == settings.sampling
    assert _schema("lipsync", "max_slowdown")["default"] == settings.max_slowdown
    assert _schema("lipsync", "model")["default"] == settings.model  # None: the model's own
    assert _schema("lipsync", "trajectory")["default"] == settings.trajectory


def test_schema_flow_vocabularies_are_the_library_s() -> None:
    assert _schema("flow", "strategy")["enum"] == list(STRATEGY_NAMES)
    face_flow = _schema("faces")["additionalProperties"]["properties"]["flow"]["properties"]
    assert face_flow["strategy"]["enum"] == list(STRATEGY_NAMES)
    method = _schema("flow", "methods")["additionalProperties"]["properties"]
    assert method["estimator"]["enum"] == list(ESTIMATORS)
    assert _schema("sweeps", "level_estimators")["items"]["enum"] == list(ESTIMATORS)


def test_the_frames_a_face_is_built_in_are_the_library_s(parser: argparse.ArgumentParser) -> None:
    from miketalk.building.frame import DEFAULT_FRAME, FRAMES

    face = _schema("faces")["additionalProperties"]["properties"]
    assert face["frame"]["enum"] == [*FRAMES, None]
    assert face["frame"]["default"] is None  # the face's own: DEFAULT_FRAME for a person's
    assert face["crop_size"]["default"] is None  # the crop's own size
    assert tuple(_choices(parser, "build", "--frame").choices) == FRAMES
    assert _choices(parser, "build", "--frame").default == DEFAULT_FRAME


def test_command_line_choices_and_defaults_are_the_library_s(
    parser: argparse.ArgumentParser,
) -> None:
    for command in ("say", "dub"):
        assert tuple(_choices(parser, command, "--lipsync-model").choices) == LIPSYNC_MODELS
        assert _choices(parser, command, "--lipsync-model").default is None  # the model's own
        assert tuple(_choices(parser, command, "--trajectory").choices) == TRAJECTORIES
        assert tuple(_choices(parser, command, "--voice").choices) == tuple(VOICES)
    assert tuple(_choices(parser, "say", "--sampling").choices) == SAMPLINGS
    assert list(_choices(parser, "dub", "--sampling").choices) == ["blur", "none"]
    # --fps is settled when the background is known: a face-crop model's video's own, else
    # the library's default
    from miketalk.api.say import own_fps

    assert _choices(parser, "say", "--fps").default is None
    assert own_fps(None, None) == LipsyncSettings().fps


def _spelled(names: tuple[str, ...]) -> list[str]:
    """Where the library's code spells a vocabulary as a tuple or list of its string values,
    outside its one home."""
    found = []
    for path in sorted((ROOT / "src").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Tuple | ast.List) and len(node.elts) >= 2:
                values = [e.value for e in node.elts if isinstance(e, ast.Constant)]
                if len(values) == len(node.elts) and set(values) <= set(names):
                    if len(set(values)) == len(names):
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return found


@pytest.mark.parametrize("names", [LIPSYNC_MODELS, SAMPLINGS, TRAJECTORIES], ids=str)
def test_no_vocabulary_is_spelled_twice(names: tuple[str, ...]) -> None:
    assert _spelled(names) == []


def test_morph_settings_defaults_are_the_morpher_s_and_the_schema_s() -> None:
    import inspect

    from miketalk.render.morph import Morpher
    from miketalk.render.morph_settings import MorphSettings

    settings = MorphSettings().to_dict()
    signature = inspect.signature(Morpher).parameters
    assert {name: signature[name].default for name in settings} == settings
    schema = _schema("morph")["properties"]
    assert {name: node["default"] for name, node in schema.items()} == {
        name: settings[name] for name in schema
    }
    face = _schema("faces")["additionalProperties"]["properties"]["morph"]["properties"]
    assert set(face) == set(schema)
    assert _schema("morph", "splat")["enum"] == face["splat"]["enum"] == ["nearest", "bilinear"]


def test_an_unknown_morph_setting_is_one_line() -> None:
    from miketalk.errors import MiketalkError
    from miketalk.render.morph_settings import MorphSettings

    with pytest.raises(MiketalkError, match="unknown morph setting smooth"):
        MorphSettings.of({"smooth": True})
    with pytest.raises(MiketalkError):
        MorphSettings.of({"splat": "cubic"})


def test_one_video_defaults_are_the_library_s(parser: argparse.ArgumentParser) -> None:
    import inspect

    from miketalk.corpus.one_video import check_video_inputs, segment_video

    corpus = _schema("faces")["additionalProperties"]["properties"]["corpus"]["properties"]
    assert corpus["heldout_seconds"]["default"] == defaults.HELDOUT_SECONDS
    assert _choices(parser, "build", "--heldout-seconds").default == defaults.HELDOUT_SECONDS
    for function in (segment_video, check_video_inputs):
        default = inspect.signature(function).parameters["heldout_seconds"].default
        assert default == defaults.HELDOUT_SECONDS


def test_the_background_s_names_and_default_are_the_library_s() -> None:
    from miketalk.composite.for_model import BACKGROUND_CHOICES, BackgroundChoice

    assert BACKGROUND_CHOICES == ("auto", "still") == tuple(BackgroundChoice)
    face = _schema("faces")["additionalProperties"]["properties"]["background"]
    assert face["default"] == defaults.BACKGROUND in BACKGROUND_CHOICES


def test_the_use_cases_settings_defaults_are_the_schema_s() -> None:
    """The workflow's face and lipsync settings and the public API's settings objects
    (:mod:`miketalk.api.settings`) agree on each default they share; the frame's rules are one
    class's (``FrameSettings``), its default one constant (``DEFAULT_FRAME``, test_workflow_settings
    follows it into the workflow's faces)."""
    from miketalk.api import BuildSettings, DubSettings, SaySettings

    face = _schema("faces")["additionalProperties"]["properties"]
    build = BuildSettings()
    assert face["crop_size"]["default"] == build.crop_size
    assert set(face["frame"]["enum"]) == {"crop", "full", None} and build.frame == "crop"
    corpus = face["corpus"]["properties"]
    assert corpus["heldout_seconds"]["default"] == build.heldout_seconds
    for settings in (SaySettings(), DubSettings()):
        assert _schema("lipsync", "max_px_per_frame")["default"] == settings.step_limit
        assert _schema("lipsync", "sampling")["default"] == settings.sampling
        assert _schema("lipsync", "model")["default"] == settings.lipsync_model
        assert _schema("lipsync", "trajectory")["default"] == settings.trajectory
    assert _schema("lipsync", "max_slowdown")["default"] == SaySettings().max_slowdown
    assert face["background"]["default"] == defaults.BACKGROUND  # SaySettings' None: auto
