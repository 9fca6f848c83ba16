"""Model directories before they are opened (miketalk.model.parts): the default model,
what a model holds, and the lip-sync model an utterance takes when none is asked for."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from miketalk.errors import MiketalkError
from miketalk.model import parts as model_parts
from miketalk.model.parts import (
    COARTICULATION,
    TRAINED_DIRECTORY,
    TRAINED_MANIFEST,
    default_lipsync_model,
    default_model_dir,
    lipsync_models_in,
    trained_trajectories,
)


def _trained(model: Path, trajectories: dict) -> None:
    (model / TRAINED_DIRECTORY).mkdir(parents=True)
    (model / TRAINED_DIRECTORY / TRAINED_MANIFEST).write_text(
        json.dumps({"trajectories": trajectories})
    )


def test_each_kind_of_utterance_takes_the_best_model_the_directory_has(tmp_path: Path) -> None:
    model = tmp_path / "model"
    model.mkdir()
    # a synthetic face's model: the paper's, whatever speaks
    assert lipsync_models_in(model) == ("paper",)
    for recorded in (False, True):
        assert default_lipsync_model(model, recorded=recorded) == "paper"
    # learned coarticulation alone: typed text and recordings both take it
    (model / COARTICULATION).write_text("{}")
    assert lipsync_models_in(model) == ("paper", "learned")
    for recorded in (False, True):
        assert default_lipsync_model(model, recorded=recorded) == "learned"
    # a trained face too: it hears a recording; typed text keeps the learned coarticulation
    _trained(model, {"window": {}, "heard": {}})
    assert lipsync_models_in(model) == ("paper", "learned", "trained")
    assert trained_trajectories(model) == ("window", "heard")
    assert default_lipsync_model(model, recorded=True) == "trained"
    assert default_lipsync_model(model, recorded=False) == "learned"
    # a missing directory has the paper's only (opening it then says what is missing)
    assert default_lipsync_model(tmp_path / "nowhere", recorded=True) == "paper"


def test_the_preferences_name_known_models_and_end_with_the_papers() -> None:
    from miketalk.lipsync.settings import LIPSYNC_MODELS, PREFERRED_LIPSYNC_MODELS

    for kind, order in PREFERRED_LIPSYNC_MODELS.items():
        assert set(order) == set(LIPSYNC_MODELS), kind
        assert order[-1] == "paper", kind  # every model has it


def test_a_broken_trained_manifest_is_one_line(tmp_path: Path) -> None:
    (tmp_path / TRAINED_DIRECTORY).mkdir()
    (tmp_path / TRAINED_DIRECTORY / TRAINED_MANIFEST).write_text("{not json")
    with pytest.raises(MiketalkError, match="cannot read the trained face"):
        default_lipsync_model(tmp_path, recorded=True)


def test_the_default_model_is_found_from_any_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    checkout = tmp_path / "checkout"
    module = checkout / "src" / "miketalk" / "talk" / "model_parts.py"
    (checkout / model_parts.DEFAULT_MODEL).mkdir(parents=True)
    monkeypatch.setattr(model_parts, "__file__", str(module))
    monkeypatch.delenv("MIKETALK_MODEL", raising=False)
    monkeypatch.delenv("MIKETALK_RESULTS", raising=False)  # the test session's empty folder
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    # not under the working directory: the checkout's
    assert default_model_dir() == checkout / model_parts.DEFAULT_MODEL
    # under the working directory: that one
    (elsewhere / model_parts.DEFAULT_MODEL).mkdir(parents=True)
    assert default_model_dir() == model_parts.DEFAULT_MODEL
    # $MIKETALK_RESULTS instead of both (its model, found or not)
    monkeypatch.setenv("MIKETALK_RESULTS", str(tmp_path / "runs"))
    runs = tmp_path / "runs"
    assert default_model_dir() == runs / model_parts.DEFAULT_MODEL.relative_to("results")
    # $MIKETALK_MODEL above all
    monkeypatch.setenv("MIKETALK_MODEL", str(tmp_path / "mine"))
    assert default_model_dir() == tmp_path / "mine"


def test_say_checks_a_model_before_numpy_loads(tmp_path: Path) -> None:
    """``say``'s checks of the model (its lip-sync model, its coarticulation read whole) load
    no numpy, OpenCV or SciPy: Festival starts once they pass, and the model's imports then
    run while Festival reads the text, not before it starts. A fresh interpreter, as the
    command line has."""
    import subprocess
    import sys

    from miketalk.draw.coarticulation import CoarticulationParams
    from miketalk.model.write import write_coarticulation
    from miketalk.visemes import VisemeTable

    model = tmp_path / "model"
    model.mkdir()
    (model / "manifest.json").write_text("{}")
    write_coarticulation(model, CoarticulationParams.prior(VisemeTable().visemes, lead=0.02))
    program = (
        "import sys\n"
        "import miketalk.cli.main\n"
        "from miketalk.api import SaySettings\n"
        "from miketalk.api.say import check\n"
        f"_, chosen = check(SaySettings(model={str(model)!r}), recorded=False)\n"
        "loaded = [m for m in ('numpy', 'cv2', 'scipy') if m in sys.modules]\n"
        "print(chosen.value, loaded)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, check=True, timeout=60
    )
    assert out.stdout.split("\n")[0] == "learned []", out.stdout + out.stderr
    # and a malformed coarticulation is still found there, in one line
    (model / COARTICULATION).write_text('{"magnitude": 1}')
    bad = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, timeout=60
    )
    assert bad.returncode != 0 and "coarticulation" in bad.stderr.lower(), bad.stderr[-500:]
