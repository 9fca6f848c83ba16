"""A video's registration to a model kept in the user's cache: made once, then read."""

from __future__ import annotations

import logging
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from test_stabilize import _write_video

from miketalk.composite import kept_registration as kept
from miketalk.composite.background import Background
from miketalk.media.frame_source import VideoFrames


def _video(path: Path, seed: int = 0, n: int = 6) -> Path:
    frames = np.random.default_rng(seed).integers(0, 256, (n, 16, 24, 3), np.uint8)
    _write_video(path, frames, "25")
    return path


def _model(digest: str = "a" * 64) -> SimpleNamespace:
    return SimpleNamespace(manifest={"files": {"background/reference.png": {"sha256": digest}}})


def _made(video: Path, n: int = 6) -> Background:
    """What a registration makes, each part its own numbers."""
    rng = np.random.default_rng(7)
    shown = np.ones(n, bool)
    shown[2] = False
    return Background(
        VideoFrames(video, count=n, fps=25.0), rng.normal(size=(n, 2, 3)),
        rng.normal(size=(8, 8, 2)).astype(np.float32), 25.0, (1, 4), str(video),
        rng.integers(0, 256, (8, 8, 3), np.uint8), shown=shown,
        shot=np.array([0, 0, -1, 1, 1, 1]), left_out=("frame 2: no face",),
        steady_shots={0: np.zeros((8, 8, 3), np.uint8), 1: np.full((8, 8, 3), 9, np.uint8)},
    )  # fmt: skip


def _same(a: Background, b: Background) -> None:
    for name in ("transforms", "field", "steady", "shown", "shot"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.array_equal(x, y) and x.dtype == y.dtype, name
    assert a.blinks == b.blinks and a.fps == b.fps and a.left_out == b.left_out
    assert sorted(a.steady_shots) == sorted(b.steady_shots)
    assert all(np.array_equal(a.steady_shots[k], b.steady_shots[k]) for k in a.steady_shots)
    assert len(a) == len(b) and a.size == b.size
    assert np.array_equal(a.frames[3], b.frames[3])


def test_a_registration_is_made_once_and_read_after(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    video = _video(tmp_path / "v.mkv")
    made: list[Background] = []

    def make():
        made.append(_made(video))
        return made[-1]

    first = kept.kept_background(_model(), video, make, check_person=True)
    assert len(made) == 1 and first is made[0]
    with caplog.at_level(logging.WARNING):
        second = kept.kept_background(_model(), video, make, check_person=True)
    assert len(made) == 1  # read, not made
    _same(first, second)
    assert "1 of its 6 frames show no one frontal face" in caplog.text  # said again
    assert "frame 2: no face" in caplog.text


@pytest.mark.parametrize("change", ["video", "model", "unchecked"])
def test_another_video_model_or_check_is_made_again(tmp_path, monkeypatch, change):
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    video = _video(tmp_path / "v.mkv")
    calls: list[int] = []

    def make():
        calls.append(1)
        return _made(video)

    kept.kept_background(_model(), video, make, check_person=True)
    model, check = _model(), True
    if change == "video":
        _video(video, seed=1)  # the same path, other bytes
    elif change == "model":
        model = _model("b" * 64)
    else:
        check = False  # made under --force: never serves a run that checks, nor one that not
    kept.kept_background(model, video, make, check_person=check)
    assert len(calls) == 2


def test_no_cache_no_checksums_or_a_broken_entry_make_it_again(tmp_path, monkeypatch):
    video = _video(tmp_path / "v.mkv")
    calls: list[int] = []

    def make():
        calls.append(1)
        return _made(video)

    monkeypatch.setenv("MIKETALK_CACHE", "off")
    for _ in range(2):
        kept.kept_background(_model(), video, make, check_person=True)
    assert len(calls) == 2
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    unnamed = SimpleNamespace(manifest={"files": {}})
    for _ in range(2):
        kept.kept_background(unnamed, video, make, check_person=True)
    assert len(calls) == 4 and not list((tmp_path / "cache").rglob("*.npz"))
    kept.kept_background(_model(), video, make, check_person=True)
    (entry,) = (tmp_path / "cache" / kept.KIND).glob("*.npz")
    entry.write_bytes(entry.read_bytes()[:100])  # cut short
    again = kept.kept_background(_model(), video, make, check_person=True)
    assert len(calls) == 6
    _same(again, _made(video))
    assert kept.kept_background(_model(), video, make, check_person=True) is not None
    assert len(calls) == 6  # the broken entry was made again whole


def test_an_entry_that_does_not_fit_the_video_is_not_used(tmp_path, monkeypatch):
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    video = _video(tmp_path / "v.mkv")
    key = kept.registration_key(_model(), video, check_person=True)
    assert kept.keep(key, _made(video), (24, 16))
    assert kept.read_kept(key, video, "v") is not None
    assert kept.keep(key, _made(video), (32, 16))  # kept for another size
    assert kept.read_kept(key, video, "v") is None
