"""Tests of miketalk_lab.evaluation.inbetween, its benchmark, and the morph's splat="bilinear"."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest

from miketalk.errors import MiketalkError
from miketalk.flow.registry import get_estimator
from miketalk.mouth.lip_colour import find_mouth_box
from miketalk.render.morph import Morpher, morph, morph_stages
from miketalk.render.splat import forward_warp
from miketalk_lab.bench.inbetween import main as bench_main
from miketalk_lab.bench.inbetween import parse_estimator
from miketalk_lab.evaluation.inbetween import COLUMNS, Method, default_methods, inbetween_table
from miketalk_lab.evaluation.inbetween_summary import summarize_inbetween, summary_markdown
from miketalk_lab.evaluation.measures import psnr
from miketalk_lab.evaluation.slomo import slomo_flows, slomo_frame


def _texture(h: int, w: int, seed: int = 0, cell: int = 6) -> np.ndarray:
    """Smooth random RGB texture in [20, 235]."""
    rng = np.random.default_rng(seed)
    coarse = rng.random((h // cell + 2, w // cell + 2, 3)).astype(np.float32)
    smooth = cv2.resize(coarse, (w + 2 * cell, h + 2 * cell), interpolation=cv2.INTER_CUBIC)
    return np.clip(20 + 215 * smooth[cell : cell + h, cell : cell + w], 0, 255).astype(np.uint8)


def _moving_clip(n: int = 13, h: int = 64, w: int = 80) -> np.ndarray:
    """Frames of a texture moving smoothly: a drift plus a growing swirl about the centre.

    Pixel ``p`` of frame ``t`` shows the texture at ``p - t * v(p)``, with ``v``
    smooth and at most about 1.3 px per frame: motion linear in time, so frame
    ``t + k/2`` is exactly half-way between frames ``t`` and ``t + k``.
    """
    big = _texture(h + 40, w + 40, seed=3)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    cy, cx = h / 2, w / 2
    vx = 0.8 + 0.02 * (ys - cy)
    vy = 0.4 - 0.02 * (xs - cx)
    frames = []
    for t in range(n):
        map_x = xs + 20 - t * vx
        map_y = ys + 20 - t * vy
        frames.append(cv2.remap(big, map_x, map_y, cv2.INTER_CUBIC))
    return np.stack(frames)


# ------------------------------------------------------------------ SloMo-style


@pytest.mark.parametrize("tau", [0.0, 0.25, 0.5, 0.8, 1.0])
def test_slomo_flows_of_a_constant_motion_are_its_two_parts(tau):
    d = np.array([3.0, -2.0], np.float32)
    f01 = np.broadcast_to(d, (5, 6, 2)).copy()
    f_t0, f_t1 = slomo_flows(f01, -f01, tau)
    # straight-line motion: back to frame 0 by -tau * d, on to frame 1 by (1 - tau) * d
    np.testing.assert_allclose(f_t0, np.broadcast_to(-tau * d, f01.shape), atol=1e-6)
    np.testing.assert_allclose(f_t1, np.broadcast_to((1 - tau) * d, f01.shape), atol=1e-6)
    assert f_t0.dtype == np.float32 and f_t1.dtype == np.float32


def test_slomo_flows_follow_the_formula_for_unequal_flows():
    rng = np.random.default_rng(0)
    f01 = rng.normal(size=(4, 5, 2)).astype(np.float32)
    f10 = rng.normal(size=(4, 5, 2)).astype(np.float32)
    tau = 0.3
    f_t0, f_t1 = slomo_flows(f01, f10, tau)
    np.testing.assert_allclose(f_t0, -(1 - tau) * tau * f01 + tau**2 * f10, atol=1e-6)
    np.testing.assert_allclose(f_t1, (1 - tau) ** 2 * f01 - tau * (1 - tau) * f10, atol=1e-6)


def test_slomo_frame_of_a_translation_is_the_half_translated_image():
    h, w, dx = 40, 60, 4.0
    big = _texture(h, w + 20, seed=1)
    image0, half, image1 = big[:, 10:-10], big[:, 8:-12], big[:, 6:-14]  # moving right by 2/frame
    flow = np.zeros((h, w, 2), np.float32)
    flow[..., 0] = dx
    frame = slomo_frame(image0, image1, flow, -flow, 0.5)
    np.testing.assert_array_equal(frame[:, 6:-6], half[:, 6:-6])


def test_slomo_rejects_a_bad_tau_and_mismatched_flows():
    flow = np.zeros((4, 4, 2), np.float32)
    with pytest.raises(MiketalkError, match="tau"):
        slomo_flows(flow, flow, 1.5)
    with pytest.raises(MiketalkError, match="flows"):
        slomo_flows(flow, np.zeros((4, 5, 2), np.float32), 0.5)


# ------------------------------------------------------------------ the table


def test_the_morph_beats_the_dissolve_on_a_known_smooth_motion():
    frames = _moving_clip()
    methods = default_methods(
        [("bergen", get_estimator("bergen", levels=3))],
        variants=("morph", "morph-nomedian", "morph-bilinear", "slomo"),
    )
    table = inbetween_table(
        frames, mouth_box=(20, 16, 40, 32), ks=(4,), methods=methods, step=2, context=None
    )
    means = table.groupby("method")["psnr_mouth"].mean()
    for name in ("morph/bergen", "morph-nomedian/bergen", "morph-bilinear/bergen"):
        assert means[name] > means["dissolve"] + 3.0, means
    assert means["slomo/bergen"] > means["dissolve"] + 3.0, means
    # the bilinear splat does not round positions: better than the paper's rounded warp
    assert means["morph-bilinear/bergen"] > means["morph-nomedian/bergen"], means


def test_table_shape_columns_and_order():
    frames = _moving_clip(n=11, h=32, w=40)
    methods = default_methods(["dis_fast"], variants=("morph", "slomo"))
    table = inbetween_table(
        frames, mouth_box=(8, 8, 24, 16), ks=(2, 4, 8), methods=methods, step=3, clip="c1"
    )
    assert tuple(table.columns) == COLUMNS
    pairs = {k: len(range(0, 11 - k, 3)) for k in (2, 4, 8)}  # t = 0, 3, ... with t + k < 11
    assert len(table) == sum(pairs.values()) * len(methods)
    assert set(table["clip"]) == {"c1"}
    assert list(dict.fromkeys(table["method"])) == ["dissolve", "morph/dis_fast", "slomo/dis_fast"]
    for k, count in pairs.items():
        ts = table.loc[(table["k"] == k) & (table["method"] == "dissolve"), "t"]
        assert list(ts) == list(range(0, 11 - k, 3))[:count]
    assert table["t"].dtype == np.int64 and table["k"].dtype == np.int64
    assert table["psnr_mouth"].between(10, 100).all()
    assert table["ssim_mouth"].between(-1, 1).all()


def test_flows_on_a_crop_and_on_the_whole_frame_give_the_same_dissolve():
    frames = _moving_clip(n=7, h=48, w=64)
    methods = [Method("dissolve", "dissolve")]
    crop = inbetween_table(frames, mouth_box=(24, 16, 16, 16), ks=(2,), methods=methods)
    whole = inbetween_table(
        frames, mouth_box=(24, 16, 16, 16), ks=(2,), methods=methods, context=None
    )
    pd.testing.assert_frame_equal(crop, whole)


def test_table_rejects_bad_arguments():
    frames = _moving_clip(n=5, h=24, w=24)
    with pytest.raises(MiketalkError, match="even"):
        inbetween_table(frames, mouth_box=(4, 4, 12, 12), ks=(3,))
    with pytest.raises(MiketalkError, match="inside"):
        inbetween_table(frames, mouth_box=(20, 4, 12, 12), ks=(2,))
    with pytest.raises(MiketalkError, match="too short"):
        inbetween_table(frames, mouth_box=(4, 4, 12, 12), ks=(8,))
    with pytest.raises(MiketalkError, match="uint8"):
        inbetween_table(frames.astype(np.float32), mouth_box=(4, 4, 12, 12))
    with pytest.raises(MiketalkError, match="variant"):
        default_methods(["dis_fast"], variants=("nope",))
    with pytest.raises(MiketalkError, match="only a dissolve"):
        Method("x", "morph")


def test_summary_counts_clips_once_and_pairs_the_gain():
    rows = []
    for clip, shift in (("a", 0.0), ("b", 2.0)):
        for t in range(3):
            rows.append((clip, t, 4, "dissolve", 30.0 + shift + t, 0.9))
            rows.append((clip, t, 4, "morph/x", 31.0 + shift + t, 0.95))
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    summary = summarize_inbetween(table)
    assert list(summary["method"]) == ["dissolve", "morph/x"]
    morph_row = summary.set_index("method").loc["morph/x"]
    assert morph_row["clips"] == 2 and morph_row["frames"] == 6
    assert morph_row["psnr_mean"] == pytest.approx(33.0)
    assert morph_row["psnr_sd"] == pytest.approx(np.std([32.0, 34.0], ddof=1))
    assert morph_row["gain_mean"] == pytest.approx(1.0)
    assert morph_row["gain_sd"] == pytest.approx(0.0)
    assert morph_row["clips_better"] == 2
    text = summary_markdown(summary)
    assert "| morph/x | 33.00 ± 1.41 (+1.00 ± 0.00, 2/2) |" in text
    assert "| dissolve | 0.9000 ± 0.0000 |" in text


# ------------------------------------------------------------------ the mouth box


def test_find_mouth_box_finds_lips_that_open_and_close():
    h, w, n = 140, 120, 12
    frames = np.empty((n, h, w, 3), np.uint8)
    frames[...] = (40, 120, 200)  # blue background
    head = np.zeros((h, w), np.uint8)
    cv2.ellipse(head, (60, 60), (35, 50), 0, 0, 360, 1, -1)
    head = head > 0
    frames[:, head] = (215, 170, 145)  # skin
    for t in range(n):
        opening = 2 + 6 * abs(np.sin(t * 0.8))
        cv2.ellipse(frames[t], (60, 88), (13, int(3 + opening)), 0, 0, 360, (190, 70, 80), -1)
        cv2.ellipse(frames[t], (60, 88), (9, int(opening)), 0, 0, 360, (60, 30, 35), -1)
        cv2.circle(frames[t], (45, 45), 4, (50, 40, 40) if t % 6 else (215, 170, 145), -1)  # blink
    x, y, bw, bh = find_mouth_box(frames, head=head, step=1)
    span = int(np.flatnonzero(head.any(axis=0))[-1] - np.flatnonzero(head.any(axis=0))[0] + 1)
    assert (bw, bh) == (round(0.45 * span), round(0.30 * span))
    # centred on the mouth (60, 88) across; up and down within a quarter of the box
    assert abs((x + bw / 2) - 60) <= 2 and abs((y + bh / 2) - 88) <= bh / 4, (x, y, bw, bh)


def test_find_mouth_box_rejects_grey_frames():
    with pytest.raises(MiketalkError, match="uint8"):
        find_mouth_box(np.zeros((4, 10, 10), np.uint8))


# ------------------------------------------------------------------ Morpher(splat="bilinear")


def _flow(h: int, w: int, dx: float, dy: float) -> np.ndarray:
    flow = np.empty((h, w, 2), np.float32)
    flow[..., 0], flow[..., 1] = dx, dy
    return flow


def test_bilinear_splat_default_is_nearest_and_endpoints_are_the_images():
    image0, image1 = _texture(30, 40, seed=1), _texture(30, 40, seed=2)
    rng = np.random.default_rng(5)
    f01 = cv2.resize(rng.uniform(-4, 4, (3, 3, 2)).astype(np.float32), (40, 30))
    f10 = cv2.resize(rng.uniform(-4, 4, (3, 3, 2)).astype(np.float32), (40, 30))
    default = Morpher(image0, image1, f01, f10)
    nearest = Morpher(image0, image1, f01, f10, splat="nearest")
    np.testing.assert_array_equal(default.frame(0.4), nearest.frame(0.4))
    bilinear = Morpher(image0, image1, f01, f10, splat="bilinear", median=False)
    np.testing.assert_array_equal(bilinear.frame(0.0), image0)
    np.testing.assert_array_equal(bilinear.frame(1.0), image1)
    assert not bilinear.frame_and_holes(0.5)[1].all()
    with pytest.raises(MiketalkError, match="splat"):
        Morpher(image0, image1, f01, f10, splat="cubic")


def test_bilinear_splat_of_a_subpixel_translation_beats_rounding():
    h, w = 40, 60
    big = _texture(h, w + 20, seed=4)
    image0, image1 = big[:, 10:-10], big[:, 7:-13]  # moving right by 3 px
    half = np.float32([[1, 0, 8.5], [0, 1, 0]])  # half(x) = big(x + 8.5): moved by 1.5 px
    truth = cv2.warpAffine(big, half, (w, h), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP)
    flow = _flow(h, w, 3.0, 0.0)
    inner = (slice(4, -4), slice(8, -8))
    nearest = morph(image0, image1, flow, -flow, 0.5, median=False)
    bilinear = morph(image0, image1, flow, -flow, 0.5, median=False, splat="bilinear")
    assert psnr(bilinear[inner], truth[inner]) > psnr(nearest[inner], truth[inner]) + 3.0


def test_bilinear_forward_warp_by_whole_pixels_is_a_shift():
    image = _texture(20, 30, seed=6)
    warped, hole = forward_warp(image, _flow(20, 30, 2.0, 1.0), 1.0, splat="bilinear")
    np.testing.assert_array_equal(warped[1:, 2:], image[:-1, :-2])
    assert hole[0].all() and hole[:, :2].all() and not hole[1:, 2:].any()
    assert (warped[hole] == 0).all()


def test_bilinear_stages_are_consistent():
    image0, image1 = _texture(24, 32, seed=7), _texture(24, 32, seed=8)
    flow = _flow(24, 32, 5.0, 0.0)
    stages = morph_stages(image0, image1, flow, -flow, 0.5, splat="bilinear")
    assert stages.hole0[:, :2].all() and stages.hole1[:, -2:].all()
    assert not stages.hole.any()
    np.testing.assert_array_equal(
        stages.filled,
        Morpher(image0, image1, flow, -flow, splat="bilinear", median=False).frame(0.5),
    )
    np.testing.assert_array_equal(
        stages.final, Morpher(image0, image1, flow, -flow, splat="bilinear").frame(0.5)
    )


# ------------------------------------------------------------------ the benchmark


def test_parse_estimator_reads_settings_as_yaml():
    label, estimator = parse_estimator("bergen:window=8.0,levels=3")
    assert label == "bergen:window=8.0,levels=3"
    assert estimator.settings["window"] == 8.0 and estimator.settings["levels"] == 3
    with pytest.raises(MiketalkError, match="setting=value"):
        parse_estimator("bergen:window")


def test_bench_writes_its_tables(tmp_path, capsys):
    from miketalk.media.video import write_mp4

    clips = tmp_path / "clips"
    write_mp4(clips / "one.mp4", _moving_clip(n=9, h=48, w=64), fps=25)
    out = tmp_path / "out"
    argv = ["--clips", str(clips), "--out", str(out), "--ks", "2", "4", "--step", "3"]
    argv += [
        "--estimators",
        "dis_fast",
        "--variants",
        "morph-bilinear",
        "--mouth-box",
        "16,12,32,24",
    ]
    assert bench_main(argv) == 0
    table = pd.read_csv(out / "inbetween.csv")
    assert tuple(table.columns) == COLUMNS
    assert set(table["method"]) == {"dissolve", "morph-bilinear/dis_fast"}
    assert len(table) == 2 * (len(range(0, 7, 3)) + len(range(0, 5, 3)))
    summary = pd.read_csv(out / "inbetween_summary.csv")
    assert set(summary["k"]) == {2, 4}
    assert pd.read_csv(out / "boxes.csv").iloc[0].tolist() == ["one", 16, 12, 32, 24]
    markdown = (out / "inbetween.md").read_text()
    assert "| morph-bilinear/dis_fast |" in markdown and markdown in capsys.readouterr().out
    assert bench_main(["--clips", str(tmp_path / "missing"), "--out", str(out)]) == 1
