"""Pieces of the held-out measures: speech span, its correlations, side-by-side, strip."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import plan
from miketalk.media.video import write_mp4
from miketalk.mouth import Eigenlips
from miketalk.speech import Phone
from miketalk.visemes import VisemeTable
from miketalk_lab.evaluation.heldout import compare, side_by_side, speech_frames, video_columns
from miketalk_lab.figures.heldout_strip import heldout_strip


def _timeline(fps: float = 25.0):
    names = ["pau", "b", "aa", "t", "pau"]
    bounds = [0.0, 0.4, 0.5, 0.7, 0.8, 1.2]
    phones = [Phone(n, bounds[i], bounds[i + 1]) for i, n in enumerate(names)]
    return plan(phones, VisemeTable(), fps=fps, duration=1.2)


def test_speech_frames_run_from_the_first_spoken_phone_to_the_last() -> None:
    timeline = _timeline()
    assert speech_frames(timeline) == slice(10, 20)  # 0.4 s to 0.8 s at 25 fps
    silent = plan([Phone("pau", 0.0, 0.4)], VisemeTable(), fps=25.0, duration=0.4)
    assert speech_frames(silent) == slice(0, 0)


def test_the_speech_correlations_ignore_the_silences() -> None:
    """A synthesis that gets the silences right and the speech backwards: high on the
    whole clip, negative inside the speech."""
    rng = np.random.default_rng(0)
    n, speech = 30, slice(10, 20)
    level = np.zeros(n)
    level[speech] = 60 + 20 * np.sin(np.arange(10))
    backwards = level.copy()
    backwards[speech] = 60 - 20 * np.sin(np.arange(10))

    def frames(levels: np.ndarray) -> np.ndarray:
        base = rng.integers(100, 140, (1, 16, 16, 3))
        out = np.repeat(base, n, axis=0).astype(float)
        out[:, 4:12, 4:12] -= levels[:, None, None, None]  # the mouth darkens as it opens
        return np.clip(out, 0, 255).astype(np.uint8)

    real, synth = frames(level), frames(backwards)
    train = np.concatenate([real, synth])[:, 4:12, 4:12].mean(axis=3)
    scores = compare(real, synth, mouth_box=(4, 4, 8, 8), eigenlips=Eigenlips(train), speech=speech)
    summary = scores.summary
    assert summary["opening_corr"] > 0.5
    assert summary["opening_corr_speech"] < -0.9
    assert "eigenlip1_corr_speech" in summary
    without = compare(real, synth, mouth_box=(4, 4, 8, 8), eigenlips=Eigenlips(train)).summary
    assert "opening_corr_speech" not in without


def test_side_by_side_columns() -> None:
    real = np.full((2, 8, 6, 3), 100, np.uint8)
    paper, learned = real + 10, real + 20
    three = side_by_side(real, paper, learned, gain=None)
    assert three.shape == (2, 8, 18, 3)
    assert (three[:, :, 12:] == 120).all()
    with_difference = side_by_side(real, paper)
    assert with_difference.shape == (2, 8, 18, 3)
    assert (with_difference[:, :, 12:] == 30).all()
    assert video_columns({"morph:m": real, "learned:m": real}, "m") == ["paper", "learned"]
    assert video_columns({"morph:m": real}, "m") == ["paper", "difference"]
    both = {"morph:m": real, "learned:m": real, "trained:m": real}
    assert video_columns(both, "m") == ["paper", "learned", "trained"]
    heard = both | {"trained_heard:m": real}
    assert video_columns(heard, "m") == ["paper", "learned", "trained", "trained_heard"]


def test_the_strip_puts_each_column_in_its_own_row(tmp_path: Path) -> None:
    timeline = _timeline()
    n, h, w = len(timeline.frames), 48, 64
    colours = [(200, 40, 40), (40, 200, 40), (40, 40, 200)]
    frames = np.zeros((n, h, 3 * w, 3), np.uint8)
    for c, colour in enumerate(colours):
        frames[:, :, c * w : (c + 1) * w] = colour
    write_mp4(tmp_path / "clip.mp4", frames, fps=timeline.fps)
    doc = timeline.to_dict() | {"columns": ["real", "paper", "learned"]}
    (tmp_path / "clip.json").write_text(json.dumps(doc))
    sheet = heldout_strip(
        tmp_path / "clip.mp4", tmp_path / "clip.json", tmp_path / "strip.png",
        mouth_box=(16, 12, 32, 24), count=4, scale=1.0,
    )  # fmt: skip
    assert (tmp_path / "strip.png").stat().st_size > 0
    # a grid of 3 rows of 4 tiles (each 24 px high with a 22 px label band, 4 px padding)
    rows = [4 + r * (24 + 22 + 4) + 12 for r in range(3)]
    for row, colour in zip(rows, colours, strict=True):
        middle = sheet[row, 4 + 16].astype(int)
        assert np.abs(middle - colour).max() < 12, (row, middle)
    with pytest.raises(MiketalkError, match="no columns"):
        heldout_strip(
            tmp_path / "clip.mp4", tmp_path / "clip.json", tmp_path / "bad.png",
            mouth_box=(16, 12, 32, 24), show=["real", "difference"], count=4, scale=1.0,
        )  # fmt: skip
    assert not (tmp_path / "bad.png").exists()
