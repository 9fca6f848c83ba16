"""The build's own lip-sync for a recording, chosen on held-back clips (issue 52 item 3).

The built model's choice end to end is in tests/product/test_build.py."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from miketalk.building import lipsync_choice
from miketalk.building.lipsync_choice import (
    MIN_CLIPS,
    MIN_T,
    choose_recording_lipsync,
    follow_score,
    paired_t,
    write_choice,
)
from miketalk.errors import MiketalkError


def _clips(seed: int, lengths=(40, 55, 30)) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.normal(size=(n, 6)) * [5, 4, 3, 2, 1, 1] for n in lengths]


def test_the_score_follows_the_movement_inside_each_clip() -> None:
    real = _clips(0)
    assert follow_score(real, real) == pytest.approx(1.0)
    assert follow_score(real, [-c for c in real]) == pytest.approx(-1.0)
    # what stays the same over a clip (a day's light) is not judged, nor the scale
    moved = [3.0 * c + np.arange(6) * (k + 1) * 10 for k, c in enumerate(real)]
    assert follow_score(real, moved) == pytest.approx(1.0)
    unrelated = follow_score(real, _clips(1))
    assert abs(unrelated) < 0.2
    # a component weighs by how much it moves: following only the largest beats only the least
    largest = [np.where(np.arange(6) == 0, c, 0.0) for c in real]
    least = [np.where(np.arange(6) == 5, c, 0.0) for c in real]
    spread = np.concatenate([c - c.mean(axis=0) for c in real]).var(axis=0)
    assert follow_score(real, largest) == pytest.approx(spread[0] / spread.sum())  # about 25/56
    assert follow_score(real, least) == pytest.approx(spread[5] / spread.sum())  # about 1/56


def _frames(directory: Path, clips: int, frames_each: int) -> Path:
    """A trained face's frames (:class:`MouthFrames`) of ``clips`` clips."""
    from miketalk.draw.trained.mouths import MouthFrames

    n = clips * frames_each
    MouthFrames(
        coords=np.zeros((n, 4)), patches=np.zeros((n, 4, 4, 3), np.uint8),
        border=np.zeros((n, 3), np.float32), clip=np.repeat(np.arange(clips), frames_each),
        clip_frame=np.tile(np.arange(frames_each), clips),
        clip_ids=tuple(f"c{k}" for k in range(clips)), mean=np.zeros(4),
        components=np.eye(4), variance=np.ones(4), region=(0, 0, 2, 2), patch=(0, 0, 4, 4),
        fps=25.0,
    ).save(directory / "trained")  # fmt: skip
    return directory


@pytest.mark.parametrize("clips,frames_each", [(MIN_CLIPS - 1, 200), (4, 25)])
def test_too_little_video_is_drawn_by_the_paper_morph(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, clips: int, frames_each: int
) -> None:
    model = _frames(tmp_path, clips, frames_each)

    def never(*args, **kwargs):
        raise AssertionError("judged on too little")

    monkeypatch.setattr(lipsync_choice, "held_back_predictions", never)
    choice = choose_recording_lipsync(tmp_path / "corpus", model)
    assert choice.recording == "paper" and choice.scores == {}
    assert choice.clips == clips and "too little" in choice.reason


@pytest.mark.parametrize(
    "case,chosen",
    [("trained", "trained"), ("learned", "learned"), ("none", "paper"), ("one clip", "paper")],
)
def test_the_best_on_the_held_back_clips_is_chosen_if_surely_better_than_the_morph(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, case: str, chosen: str
) -> None:
    model = _frames(tmp_path, 4, 60)
    real = _clips(2, (60, 60, 60, 60))
    real[3] = 0.3 * real[3]  # a quiet clip: little weight in the pooled score
    rng = np.random.default_rng(3)

    def noisy(level: float) -> list[np.ndarray]:
        return [c + rng.normal(size=c.shape) * level for c in real]

    paper, good, bad = noisy(2.0), noisy(0.3), noisy(8.0)
    predicted = {"paper": paper, "learned": bad, "trained": bad}
    if case in ("trained", "learned"):
        predicted[case] = good
    elif case == "one clip":  # better on three clips, lost on the quiet one
        predicted["trained"] = [*good[:3], rng.normal(size=real[3].shape)]
    monkeypatch.setattr(lipsync_choice, "held_back_predictions", lambda *a, **k: (real, predicted))
    choice = choose_recording_lipsync(tmp_path / "corpus", model)
    assert choice.recording == chosen
    assert set(choice.scores) == set(choice.t) == {"paper", "learned", "trained"}
    assert all(len(v) == 4 for v in choice.clip_scores.values())
    if case == "one clip":  # the best over all the clips, not surely better clip by clip
        assert choice.scores["trained"] > choice.scores["paper"]
        assert choice.t["trained"] < MIN_T
    if chosen != "paper":
        assert choice.scores[chosen] == max(choice.scores.values())
        assert choice.t[chosen] >= MIN_T
    assert f"paper {choice.scores['paper']:.2f}" in choice.reason


def test_the_paired_t_of_clip_scores() -> None:
    assert paired_t([0.5, 0.6, 0.7], [0.4, 0.5, 0.6]) > 1e4  # the same gain on every clip
    assert paired_t([0.5, 0.2], [0.2, 0.5]) == 0.0
    assert paired_t([0.9], [0.1]) == 0.0  # one clip says nothing of the spread
    d = np.array([0.1, 0.3, -0.1, 0.2])
    assert paired_t(d, np.zeros(4)) == pytest.approx(d.mean() / (d.std(ddof=1) / 2), abs=1e-3)


def test_a_model_draws_a_recording_with_its_builds_choice(tmp_path: Path) -> None:
    from miketalk.model.parts import (
        LIPSYNC_CHOICE,
        choose_lipsync_model,
        default_lipsync_model,
        own_recording_model,
    )

    model = tmp_path / "m"
    (model / "trained").mkdir(parents=True)
    doc = {
        "format": "miketalk-trained/1",
        "default": "window",
        "fit": {"heard": {"cv_r2": [0.0, 0.0]}},
        "trajectories": {"window": {}, "heard": {}},
    }
    (model / "trained" / "trained.json").write_text(json.dumps(doc), "utf-8")
    (model / "coarticulation.json").write_text("{}", "utf-8")
    # built before the choice: its trained face predicted nothing, so the morph
    assert own_recording_model(model) == "paper"
    for name in ("learned", "trained", "paper"):
        write_choice(model, lipsync_choice.LipsyncChoice(name, {name: 0.3}, 8, 14.0, "why"))
        assert own_recording_model(model) == name
        assert default_lipsync_model(model, recorded=True) == name
        if name != "learned":  # (choosing it reads the coarticulation, a stand-in here)
            assert choose_lipsync_model(model, None, recorded=True).value == name
        assert default_lipsync_model(model, recorded=False) == "learned"  # typed text: unchanged
        # what is asked for is drawn
        assert choose_lipsync_model(model, "paper", recorded=True).value == "paper"
    (model / LIPSYNC_CHOICE).write_text('{"recording": "mouth"}', "utf-8")
    with pytest.raises(MiketalkError, match="lip-sync choice") as err:
        own_recording_model(model)
    assert "\n" not in str(err.value)
