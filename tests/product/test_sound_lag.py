"""The lag of a video's sound behind its mouth as a model records it, and its use (issue 52).

The measure lives in the evaluation (tests/lab/test_sound_sync.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from miketalk.corpus.clip_sources import _lagged
from miketalk.corpus.sound_lag import KEY, led, model_sound_lag
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming


def test_a_recordings_phones_lead_and_its_sound_follows() -> None:
    phones = [Phone("pau", 0.0, 0.3), Phone("b", 0.3, 0.4), Phone("aa", 0.4, 0.7),
              Phone("pau", 0.7, 1.0)]  # fmt: skip
    samples = np.arange(16000, dtype=np.int16)
    moved, heard = led(phones, samples, 16000, 0.1, 1.0)
    assert [p.name for p in moved] == ["pau", "b", "aa", "pau"]
    assert moved[0].start == 0.0 and moved[-1].end == 1.0
    assert moved[1].start == pytest.approx(0.2) and moved[2].end == pytest.approx(0.6)
    assert heard[0] == 1600 and len(heard) == len(samples) and heard[-1] == 0
    later, behind = led(phones, samples, 16000, -0.1, 1.0)
    assert later[1].start == pytest.approx(0.4) and behind[1600] == 0 and behind[0] == 0
    same, sound = led(phones, samples, 16000, 0.0, 1.0)
    assert same == phones and sound is samples


def test_the_words_of_a_lagged_clip_come_as_much_earlier() -> None:
    words = (WordTiming("bin", 0.05, 0.3), WordTiming("blue", 0.3, 0.6))
    got = _lagged(words, 0.1)
    assert got[0].start == 0.0 and got[0].end == pytest.approx(0.2)
    assert got[1].start == pytest.approx(0.2) and got[1].end == pytest.approx(0.5)
    assert _lagged(words, 0.0) == list(words)


def test_a_model_keeps_its_lag_in_its_segments(tmp_path: Path) -> None:
    assert model_sound_lag(tmp_path) == 0.0
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "segments.json").write_text(json.dumps({KEY: 0.067}), "utf-8")
    assert model_sound_lag(tmp_path) == 0.067


def _trained_face(model: Path, r2: float | None) -> Path:
    """A model folder with a trained face whose build measured ``r2`` (None: no measure)."""
    (model / "trained").mkdir(parents=True)
    fit = {"frames": 415, "clips": 8}
    if r2 is not None:
        fit |= {"window": {"cv_r2": [0.5, 0.1]}, "heard": {"cv_r2": [0.0, r2, 0.02]}}
    doc = {"format": "miketalk-trained/1", "default": "window", "fit": fit,
           "trajectories": {"window": {}, "heard": {}}}  # fmt: skip
    (model / "trained" / "trained.json").write_text(json.dumps(doc), "utf-8")
    (model / "coarticulation.json").write_text("{}", "utf-8")
    return model


def test_a_trained_face_that_predicts_nothing_leaves_recordings_to_the_morph(
    tmp_path: Path,
) -> None:
    from miketalk.model.parts import choose_lipsync_model, default_lipsync_model, trained_predicts

    weak = _trained_face(tmp_path / "weak", 0.0)
    strong = _trained_face(tmp_path / "strong", 0.42)
    old = _trained_face(tmp_path / "old", None)
    assert trained_predicts(weak) == (False, 0.02)  # its best component
    assert trained_predicts(strong) == (True, 0.42)
    assert trained_predicts(old) == (True, None)
    assert default_lipsync_model(weak, recorded=True) == "paper"
    assert default_lipsync_model(strong, recorded=True) == "trained"
    assert default_lipsync_model(old, recorded=True) == "trained"
    assert default_lipsync_model(weak, recorded=False) == "learned"  # typed text: unchanged
    assert choose_lipsync_model(weak, None, recorded=True).value == "paper"
    # what is asked for is drawn
    assert choose_lipsync_model(weak, "trained", recorded=True).value == "trained"
    assert choose_lipsync_model(weak, None, trajectory="heard", recorded=True).value == "trained"
