"""dlib's face landmarks and the held-out landmark measures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from miketalk.errors import MiketalkError
from miketalk_lab.evaluation.heldout import summarize
from miketalk_lab.evaluation.landmark_scores import (
    LANDMARK_MEASURES,
    ClipLandmarks,
    landmark_scores,
    paired_differences,
)
from miketalk_lab.evaluation.landmarks import (
    delayed,
    face_landmarks,
    lip_opening,
    mouth_lmd,
    mouth_points,
    mouth_width,
)

CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbas3a.mpg"


@pytest.fixture(scope="module")
def s1_clip() -> tuple[np.ndarray, ClipLandmarks]:
    """A committed GRID s1 clip ("bin blue at s three again") and its landmarks."""
    from miketalk.media.decode import read_video

    frames, _ = read_video(CLIP)
    return frames, ClipLandmarks(face_landmarks(), frames)


def test_the_mouth_points_land_on_the_mouth(s1_clip) -> None:
    """On a real s1 clip the 20 mouth points lie in the mouth box the project finds from the
    lips' redness (no landmarks involved), and the inner lips part as he speaks."""
    from miketalk.mouth.lip_colour import find_mouth_box

    frames, marks = s1_clip
    x, y, w, h = find_mouth_box(frames)
    mouth = mouth_points(marks.real)
    assert mouth.shape == (len(frames), 20, 2)
    inside = (
        (mouth[..., 0] >= x)
        & (mouth[..., 0] < x + w)
        & (mouth[..., 1] >= y)
        & (mouth[..., 1] < y + h)
    )
    assert inside.mean() > 0.95, inside.mean()
    # the face box holds the whole face: the mouth in its lower third
    bx, by, bw, bh = marks.box
    centre = mouth.mean(axis=(0, 1))
    assert bx < centre[0] < bx + bw and by + 0.6 * bh < centre[1] < by + bh
    opening = lip_opening(marks.real)
    assert opening[0] < 3 and opening.max() > 6  # closed at rest, open in the speech
    assert (mouth_width(marks.real) > 20).all()


def test_a_frame_is_at_no_distance_from_itself(s1_clip) -> None:
    frames, marks = s1_clip
    again = face_landmarks().points(frames[:10], marks.box)  # marked again, not remembered
    np.testing.assert_array_equal(again, marks.real[:10])  # the same box, the same points
    assert (mouth_lmd(again, marks.real[:10]) == 0).all()
    _, summary = landmark_scores(marks.real, marks.real, speech=slice(15, 60), max_lag=5)
    assert summary["mouth_lmd"] == 0
    assert summary["lip_opening_corr_speech"] == pytest.approx(1)
    assert summary["lip_opening_amplitude_speech"] == pytest.approx(1)
    assert summary["lip_opening_lag"] == 0


def test_a_frame_drawn_again_is_marked_once(s1_clip) -> None:
    """A clip's repeated frames (a held pose, a still renderer, the real frames) are marked
    once and given the points the predictor gave them."""
    frames, marks = s1_clip
    landmarks = face_landmarks()
    calls = []
    predictor = landmarks._predictor
    landmarks._predictor = lambda frame, rect: calls.append(1) or predictor(frame, rect)
    try:
        held = np.concatenate([frames[3:4].repeat(5, axis=0), frames[:4]])
        points = marks.of(held)
    finally:
        landmarks._predictor = predictor
    assert calls == []  # every one of them is one of the real frames, marked already
    np.testing.assert_array_equal(points, marks.real[[3, 3, 3, 3, 3, 0, 1, 2, 3]])
    fresh = landmarks.points(held, marks.box, known={})
    np.testing.assert_array_equal(fresh, points)
    brighter = np.clip(held.astype(int) + 9, 0, 255).astype(np.uint8)
    known: dict = {}
    landmarks._predictor = lambda frame, rect: calls.append(1) or predictor(frame, rect)
    try:
        landmarks.points(brighter, marks.box, known=known)
    finally:
        landmarks._predictor = predictor
    assert len(calls) == len(known) == 4  # nine frames, four of them distinct


def test_the_real_mouth_late_is_near_but_not_the_real_mouth(s1_clip) -> None:
    frames, marks = s1_clip
    np.testing.assert_array_equal(marks.late(2)[5:], marks.of(delayed(frames, 2))[5:])
    scores = {
        k: landmark_scores(marks.real, marks.late(k), speech=slice(15, 60), max_lag=5)[1]
        for k in (1, 2)
    }
    for k, summary in scores.items():
        assert summary["lip_opening_corr_speech"] < 1
        assert summary["mouth_lmd"] > 0
        assert summary["lip_opening_lag"] == k
    assert scores[1]["mouth_lmd"] < scores[2]["mouth_lmd"]
    assert scores[1]["lip_opening_corr_speech"] > scores[2]["lip_opening_corr_speech"]


def _talking_points(n: int, seed: int = 0) -> np.ndarray:
    """Landmarks whose inner lips open and close smoothly at random, straight up and down."""
    rng = np.random.default_rng(seed)
    points = np.tile(rng.uniform(100, 200, (1, 68, 2)), (n, 1, 1))
    opening = np.convolve(rng.uniform(size=n + 8), np.ones(5) / 5, mode="same")[4:-4]
    for upper, lower in ((61, 67), (62, 66), (63, 65)):
        points[:, lower] = points[:, upper] + np.stack([0 * opening, 1 + 6 * opening], axis=1)
    return points


@pytest.mark.parametrize("k", [0, 1, 2, 3])
def test_the_opening_of_a_mouth_k_frames_late_lags_by_k(k: int) -> None:
    real = _talking_points(80)
    _, summary = landmark_scores(real, delayed(real, k), speech=slice(10, 70), max_lag=5)
    assert summary["lip_opening_lag"] == k
    _, early = landmark_scores(delayed(real, k), real, speech=slice(10, 70), max_lag=5)
    assert early["lip_opening_lag"] == -k


def test_amplitude_and_width() -> None:
    real = _talking_points(50)
    half = real.copy()
    half[:, 65:68] = (real[:, 61:64][:, ::-1] + real[:, 65:68]) / 2  # half as open
    _, summary = landmark_scores(real, half, speech=slice(0, 50), max_lag=5)
    assert summary["lip_opening_amplitude_speech"] == pytest.approx(0.5)
    assert summary["lip_opening_corr_speech"] == pytest.approx(1)
    assert summary["mouth_width_corr_speech"] == 0  # the width does not move in either
    _, still = landmark_scores(
        real, np.repeat(real[:1], 50, axis=0), speech=slice(0, 50), max_lag=5
    )
    assert np.isnan(still["lip_opening_lag"])  # a still face has no lag
    assert still["lip_opening_amplitude_speech"] == 0
    assert summary["mouth_lmd"] > 0
    with pytest.raises(MiketalkError, match="68, 2"):
        landmark_scores(real[:, :20], half[:, :20], speech=slice(0, 50), max_lag=5)


def test_delayed() -> None:
    values = np.arange(5)
    np.testing.assert_array_equal(delayed(values, 2), [0, 0, 0, 1, 2])
    np.testing.assert_array_equal(delayed(values, 0), values)
    np.testing.assert_array_equal(delayed(values, 9), [0, 0, 0, 0, 0])
    with pytest.raises(MiketalkError):
        delayed(values, -1)


def test_paired_differences_against_the_morph() -> None:
    rows = []
    for clip, base in (("a", 2.0), ("b", 3.0)):
        rows += [
            {"clip": clip, "renderer": "morph", "model": "m", "mouth_lmd": base},
            {
                "clip": clip,
                "renderer": "still",
                "model": "m",
                "mouth_lmd": base + 1 + (clip == "b"),
            },
        ]
    table = pd.DataFrame(rows)
    paired = paired_differences(table, reference=("morph", "m"))
    assert paired.loc[("still", "m"), "mouth_lmd_vs_morph_mean"] == pytest.approx(1.5)
    assert paired.loc[("still", "m"), "mouth_lmd_vs_morph_sd"] == pytest.approx(np.sqrt(0.5))
    assert paired.loc[("morph", "m"), "mouth_lmd_vs_morph_mean"] == 0
    summary = summarize(table, reference=("morph", "m")).set_index("renderer")
    assert summary.loc["still", "mouth_lmd_mean"] == pytest.approx(4.0)
    assert summary.loc["still", "mouth_lmd_vs_morph_mean"] == pytest.approx(1.5)
    assert "mouth_lmd_vs_morph_mean" not in summarize(table).columns
    assert paired_differences(table, reference=("morph", "other")).empty
    assert "lip_opening_corr_speech" in LANDMARK_MEASURES


def test_the_bench_reports_each_lip_sync_renderer_against_the_morph() -> None:
    from miketalk_lab.bench.real_face import RENDERER_FIGURES, landmark_figures

    rows = []
    for clip, lag in (("a", 0), ("b", 2)):
        for renderer, model, lmd in (
            ("morph", "own", 2.0),
            ("learned", "own", 1.5),
            ("still", "own", 3.0),
            ("morph", "other", 9.0),
        ):
            rows.append(
                {"clip": clip, "renderer": renderer, "model": model, "lip_opening_lag": lag}
                | dict.fromkeys(RENDERER_FIGURES, lmd + (clip == "b"))
            )
    figures = landmark_figures(pd.DataFrame(rows), "own")
    assert figures["morph_mouth_lmd_mean"] == pytest.approx(2.5)
    assert figures["learned_minus_morph_mouth_lmd_mean"] == pytest.approx(-0.5)
    assert figures["learned_minus_morph_mouth_lmd_sd"] == pytest.approx(0)
    assert figures["learned_lip_opening_lag_within_1_fraction"] == 0.5
    assert not any(key.startswith("still_") for key in figures)


def test_the_bench_finds_the_faces_own_model_and_sweeps_each_trained_renderer(
    tmp_path: Path,
) -> None:
    """The own model is the one the baselines draw (not a name written in the bench), and the
    sweep reports the morph and both trained renderers of that model only."""
    from miketalk_lab.bench.real_face import RENDERER_FIGURES, own_model, sweep_figures

    rows = [
        {"training_clips": n, "renderer": renderer, "model": model}
        | {f"{m}_mean": float(n) for m in RENDERER_FIGURES}
        for n in (5, 40)
        for renderer, model in (
            ("still", "dis/direct"), ("morph", "dis/direct"), ("morph", "bergen/bridge"),
            ("trained", "dis/direct"), ("trained_heard", "dis/direct"), ("learned", "dis/direct"),
        )
    ]  # fmt: skip
    table = pd.DataFrame(rows)
    assert own_model(table) == "dis/direct"
    with pytest.raises(ValueError, match="still"):
        own_model(table[table["renderer"] != "still"])
    table.to_csv(tmp_path / "training_clips.csv", index=False)
    figures = sweep_figures(tmp_path)
    renderers = {"morph", "trained", "trained_heard"}
    assert len(figures) == 2 * len(renderers) * len(RENDERER_FIGURES)
    assert figures["sweep_n40_trained_heard_mouth_lmd_mean"] == 40.0
    assert sweep_figures(tmp_path / "none") == {}


def test_the_bench_keeps_the_dubs_means(tmp_path: Path) -> None:
    from miketalk_lab.bench.real_face import DUB_FIGURES, dub_figures

    row = {f"{k}_mean": float(i) for i, k in enumerate(DUB_FIGURES)}
    row |= {f"{k}_sd": 9.0 for k in DUB_FIGURES} | {"clips": 40, "renderer": "trained_heard"}
    pd.DataFrame([row]).to_csv(tmp_path / "summary.csv", index=False)
    figures = dub_figures(tmp_path / "summary.csv")
    assert figures["dub_psnr_frame"] == 0.0 and figures["dub_mouth_lmd"] == 2.0
    assert figures["dub_jitter_beyond"] == len(DUB_FIGURES) - 1.0
    assert "dub_sharpness_ratio" in figures and "dub_roundtrip_sharpness_ratio" in figures
    assert len(figures) == len(DUB_FIGURES) and dub_figures(tmp_path / "none.csv") == {}


def test_mouth_to_nose_jitter_and_eye_openness() -> None:
    from miketalk_lab.evaluation.landmarks import eye_openness, mouth_nose_jitter

    rng = np.random.default_rng(0)
    base = rng.uniform(0, 100, (68, 2))
    head = np.cumsum(rng.normal(0, 2, (30, 1, 2)), axis=0)  # the head wanders
    points = base + head
    assert mouth_nose_jitter(points) == pytest.approx(0.0, abs=1e-9)  # one head: no slide
    slid = points.copy()
    slid[:, 48:68] += np.arange(30)[:, None, None] * np.array([0.6, 0.8])  # 1 px a frame
    assert mouth_nose_jitter(slid) == pytest.approx(1.0)
    eye = np.array([[0, 0], [1, -1], [2, -1], [3, 0], [2, 1], [1, 1]], float)  # 3 wide, 2 tall
    marks = np.zeros((2, 68, 2))
    marks[:, 36:42] = eye
    marks[:, 42:48] = eye
    marks[1, [37, 38, 43, 44], 1] = -0.1  # the lids close
    marks[1, [40, 41, 46, 47], 1] = 0.1
    assert eye_openness(marks) == pytest.approx([2 / 3, 0.2 / 3])
