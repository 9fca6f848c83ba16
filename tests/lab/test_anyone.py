"""The held-out bench of people other than s1 (``miketalk_lab.bench.anyone``): its measures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from miketalk_lab.bench.anyone import (
    FOLDS,
    opening,
    real_landmarks,
    scores,
    table,
)
from miketalk_lab.evaluation.landmarks import delayed
from miketalk_lab.evaluation.sound_sync import speech_span

CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbas3a.mpg"


def _face(openings: np.ndarray, eyes: float = 50.0) -> np.ndarray:
    """Landmarks ``(N, 68, 2)``: eyes ``eyes`` px apart, the inner lips ``openings`` px apart."""
    n = len(openings)
    points = np.zeros((n, 68, 2))
    points[:, 36:42] = (100.0, 100.0)
    points[:, 42:48] = (100.0 + eyes, 100.0)
    points[:, 48:60] = (125.0, 160.0)
    points[:, 60:65, 1] = 160.0 - openings[:, None] / 2
    points[:, 65:68, 1] = 160.0 + openings[:, None] / 2
    points[:, 60:68, 0] = 125.0
    return points


def test_the_opening_is_divided_by_the_eye_distance() -> None:
    wide = _face(np.array([10.0, 20.0]), eyes=100.0)
    near = _face(np.array([5.0, 10.0]), eyes=50.0)
    assert np.allclose(opening(wide), [0.1, 0.2])
    assert np.allclose(opening(wide), opening(near))


def test_the_real_mouth_a_frame_late_scores_lag_one_and_full_amplitude() -> None:
    rng = np.random.default_rng(0)
    real = _face(5 + 4 * np.sin(np.arange(90) / 3) + rng.normal(0, 0.5, 90))
    got = scores(real, delayed(real, 1), slice(10, 80))
    assert got["lag"] == 1.0
    assert got["r_best"] > 0.99
    assert 0.9 < got["amplitude"] < 1.1
    assert got["r"] < 0.99
    still = scores(real, _face(np.full(90, 5.0)), slice(10, 80))
    assert still["r"] == 0.0 and still["amplitude"] < 1e-9
    assert still["lmd"] > got["lmd"]
    moved = real.copy()
    moved[:, 48:68] += (5.0, 0.0)  # the mouth put 5 px aside, eyes 50 px apart
    assert scores(real, moved, slice(10, 80))["centre"] == pytest.approx(5 / 50 * 72)


def test_the_speech_is_where_the_sound_is() -> None:
    rate, fps = 16000, 25.0
    audio = np.zeros(rate * 3, np.int16)
    t = np.arange(rate) / rate
    audio[rate : 2 * rate] = (8000 * np.sin(2 * np.pi * 200 * t)).astype(np.int16)
    span = speech_span(audio, rate, fps, 75)
    assert (span.start, span.stop) == (25, 50)


def test_a_real_clips_landmarks_follow_its_mouth() -> None:
    points, boxes = real_landmarks(CLIP)
    assert len(points) == len(boxes) == 75
    mouth = opening(points)
    assert mouth[:5].mean() < mouth[20:60].max() / 2  # closed in the silence, open in speech


def test_every_address_is_held_out_once() -> None:
    held = [a for fold in FOLDS for a in fold]
    assert sorted(held) == [f"wa0{k}" for k in range(1, 9)]


def test_the_table_lists_the_renderers_and_the_calibration() -> None:
    rows = pd.DataFrame(
        [
            {"clip": c, "renderer": r, "r": v, "amplitude": 1.0, "lag": 0.0, "r_best": v,
             "lmd": 2.0}
            for c in ("wa06", "wa08")
            for r, v in (("morph", 0.3), ("unrelated", 0.0), ("real_late1", 0.7))
        ]
    )  # fmt: skip
    text = table(rows)
    lines = text.splitlines()
    assert [ln.split(" | ")[0] for ln in lines[2:]] == ["| morph", "| unrelated", "| real_late1"]
    assert "06:+0.30 08:+0.30" in lines[2]
    rows["lip_dE"] = 3.0
    assert "| 3.00 (0.00) |" in table(rows).splitlines()[2]
    assert "| 2.00 (0.00) |  |  |  | 06:" in lines[2]  # no lip colours measured: empty cells
    with pytest.raises(KeyError):
        table(rows.drop(columns="r"))


def test_the_lips_colour_is_read_inside_the_lip_line() -> None:
    from miketalk_lab.evaluation.mouth_follow import lip_colours

    points, _ = real_landmarks(CLIP)
    lab = lip_colours(CLIP, points[:10])
    assert lab.shape == (10, 3) and np.isfinite(lab).all()
    assert (lab[:, 1] > 5).all()  # lips are red: a* well above grey's 0
