"""The pure helpers of the plain-vs-hard held-out bench (miketalk_lab.bench.hard_heldout)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from miketalk.errors import MiketalkError
from miketalk_lab.bench.hard_heldout import pair_models, strip_image
from miketalk_lab.bench.train_test import draw_training, split_clips
from miketalk_lab.evaluation.paired import paired, target_verdict


def test_split_clips_keeps_the_orders_and_never_shares_a_clip():
    pool = [f"c{i:02d}" for i in range(12)]
    train, test = split_clips(pool, ["c05", "c01", "c03"], ["c07", "c03", "zz"], 5, 3)
    assert test[:2] == ["c07", "c03"]  # the test order first ("zz" is not in the pool)
    assert train[:2] == ["c05", "c01"]  # c03 is a test clip: not trained on
    assert len(train) == 5 and len(test) == 3
    assert not set(train) & set(test)
    assert test[2] not in {"c05", "c01", "c03"}  # a spare test clip no training list names


def test_split_clips_too_small_a_pool():
    with pytest.raises(MiketalkError, match="not enough"):
        split_clips(["a", "b", "c"], [], [], 2, 2)


def test_paired_differences_and_interval():
    a = pd.Series([1.0, 2.0, 3.0, np.nan], index=["x", "y", "z", "w"])
    b = pd.Series([1.5, 2.5, 3.0, 9.0, 7.0], index=["x", "y", "z", "w", "v"])
    out = paired(a, b)
    assert out["clips"] == 3  # w has no value in a, v is not in a
    assert out["diff_mean"] == pytest.approx(1 / 3)
    sd = np.std([0.5, 0.5, 0.0], ddof=1)
    assert out["diff_sd"] == pytest.approx(sd)
    half = 4.302652729911275 * sd / math.sqrt(3)  # t(0.975, 2)
    assert out["diff_low"] == pytest.approx(1 / 3 - half)
    assert out["diff_high"] == pytest.approx(1 / 3 + half)
    assert out["a_mean"] == pytest.approx(2.0) and out["b_mean"] == pytest.approx(7 / 3)


def test_paired_one_pair_has_no_interval():
    out = paired(pd.Series([1.0], index=["x"]), pd.Series([2.0], index=["x"]))
    assert out["clips"] == 1 and out["diff_mean"] == 1.0
    assert math.isnan(out["diff_low"]) and math.isnan(out["diff_sd"])


def test_target_verdict():
    assert target_verdict(0.02, -0.01, 0.025, 0.03) == "met (interval too)"
    assert target_verdict(0.02, -0.05, 0.09, 0.03) == "met (mean only)"
    assert target_verdict(-0.04, -0.05, -0.03, 0.03) == "not met"
    assert target_verdict(float("nan"), float("nan"), float("nan"), 0.03) == "not met"


def test_pair_models_pairs_by_clip_and_sets_targets():
    rows = []
    for clip, (ra, rb) in {"p": (0.5, 0.52), "q": (0.6, 0.61), "r": (0.7, 0.69)}.items():
        for model, test, r, lmd in (("plain", "plain", ra, 2.0), ("hard", "hard", rb, 2.05)):
            rows.append({"clip": clip, "model": model, "test": test, "renderer": "morph",
                         "lip_opening_corr_speech": r, "mouth_lmd": lmd})  # fmt: skip
    table = pd.DataFrame(rows)
    out = pair_models(table, ("plain", "plain"), ("hard", "hard"), renderers=("morph", "learned"))
    assert list(out["measure"]) == ["lip_opening_corr_speech", "mouth_lmd"]  # no learned rows
    r = out.set_index("measure").loc["lip_opening_corr_speech"]
    assert r["clips"] == 3 and r["diff_mean"] == pytest.approx(0.02 / 3)
    assert r["target"] == 0.03 and r["verdict"].startswith("met")
    lmd = out.set_index("measure").loc["mouth_lmd"]
    assert lmd["diff_mean"] == pytest.approx(0.05) and lmd["target"] == 0.1


def test_strip_image_rows_and_columns():
    a = np.zeros((10, 4, 6, 3), np.uint8)
    b = np.full((12, 4, 6, 3), 100, np.uint8)
    image = strip_image([a, b], columns=3)
    assert image.shape == (4 + 2 + 4, 3 * 6, 3)
    assert (image[4:6] == 255).all() and (image[6:] == 100).all() and (image[:4] == 0).all()


def test_draw_training_is_seeded_and_never_draws_a_test_clip():
    pool = [f"c{i:02d}" for i in range(20)]
    test = ["c03", "c11"]
    one = draw_training(pool, test, 8, 1)
    assert one == draw_training(list(reversed(pool)), test, 8, 1)  # the pool's order is not used
    assert len(set(one)) == 8 and not set(one) & set(test)
    assert draw_training(pool, test, 8, 2) != one  # another draw, other clips
    with pytest.raises(MiketalkError, match="numbered from 1"):
        draw_training(pool, test, 8, 0)
    with pytest.raises(MiketalkError, match="not enough"):
        draw_training(pool, test, 19, 1)


def test_draws_table_averages_over_draws_and_measures_the_spread():
    from miketalk_lab.bench.hard_draws import draws_table

    def table(plain, hard):
        rows = []
        for clip, a, b in zip("pqr", plain, hard, strict=True):
            for model, r in (("plain", a), ("hard", b)):
                rows.append({"clip": clip, "model": model, "test": model, "renderer": "morph",
                             "lip_opening_corr_speech": r})  # fmt: skip
        return pd.DataFrame(rows)

    out = draws_table({0: table([0.5, 0.6, 0.7], [0.56, 0.66, 0.76]),
                       1: table([0.6, 0.7, 0.8], [0.60, 0.70, 0.80])})  # fmt: skip
    by = out.set_index("comparison")
    assert by.loc["hard - plain, draw 0", "diff_mean"] == pytest.approx(0.06)
    assert by.loc["hard - plain, draw 0", "verdict"] == "not met"
    assert by.loc["hard - plain, draw 1", "diff_mean"] == pytest.approx(0.0)
    mean = by.loc["hard - plain, over draws 0, 1"]
    assert mean["diff_mean"] == pytest.approx(0.03) and mean["kind"] == "mean"
    assert by.loc["plain 1 - plain 0", "diff_mean"] == pytest.approx(0.1)
    assert by.loc["hard 1 - hard 0", "diff_mean"] == pytest.approx(0.04)
    assert by.loc["plain 1 - plain 0", "verdict"] == ""  # no target on the spread
