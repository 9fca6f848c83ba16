"""The person-independent mouth model and its adaptation to a face (draw.trained.pooled)."""

from __future__ import annotations

import hashlib
import json
from importlib import resources

import numpy as np
import pytest

from miketalk.draw.trained.build import TrainedFace
from miketalk.draw.trained.pooled import (
    GEOMETRY,
    POOLED_FILE,
    PROVENANCE,
    PooledModel,
    fit_pooled,
    from_arrays,
    mouth_geometry,
    package_pooled,
    to_arrays,
)
from miketalk.draw.trained.selection import SelectionSettings
from miketalk.draw.trained.training import TrainingSet
from miketalk.errors import SettingError
from miketalk.lipsync.settings import resolve_lipsync_model
from miketalk.speech.acoustic import RATE, Recording
from miketalk.speech.types import Phone
from miketalk.visemes import VisemeTable

FPS = 25.0


def _clip(rng: np.random.Generator) -> tuple[tuple[Phone, ...], np.ndarray, Recording]:
    """Random syllables with a sound as loud as each vowel's random stress."""
    t, phones, level = 0.3, [Phone("pau", 0.0, 0.3)], [0.0]
    for _ in range(8):
        for name in ("m", str(rng.choice(("aa", "iy", "uw", "ae")))):
            d = 0.08 if name == "m" else float(rng.uniform(0.1, 0.22))
            phones.append(Phone(name, t, t + d))
            level.append(0.0 if name == "m" else float(rng.uniform(0.2, 1.0)))
            t += d
    phones.append(Phone("pau", t, t + 0.3))
    level.append(0.0)
    n = round((t + 0.3) * RATE)
    which = np.searchsorted([p.start for p in phones], np.arange(n) / RATE, "right") - 1
    tone = np.sin(2 * np.pi * 180 * np.arange(n) / RATE) + 0.3 * rng.standard_normal(n)
    sound = (3000 * np.array(level)[np.clip(which, 0, None)] * tone).astype(np.int16)
    times = np.arange(round((t + 0.3) * FPS)) / FPS
    return tuple(phones), times, Recording(sound, RATE)


def _pooled(table: VisemeTable, rng: np.random.Generator, k: int = 3, variants: int = 1):
    """A pooled model of random weights (what each variant predicts is a fixed function of
    the speech)."""
    probe = PooledModel(tuple(table.visemes), 3, 0.04, 3, 0.02, np.zeros((1, 1, k)),
                        np.zeros((1, k)), ("probe",), "test")  # fmt: skip
    phones, times, sound = _clip(rng)
    n_features = probe.features(phones, times, table, sound).shape[1]
    weights = rng.standard_normal((variants, n_features, k)) / np.sqrt(n_features)
    names = tuple(f"v{i}" for i in range(variants))
    return PooledModel(probe.visemes, 3, 0.04, 3, 0.02, weights, np.zeros((variants, k)), names,
                       "test")  # fmt: skip


def test_the_package_ships_its_pooled_model_with_its_provenance() -> None:
    model = package_pooled()
    data = resources.files("miketalk").joinpath(f"data/{POOLED_FILE}").read_bytes()
    assert model.digest == hashlib.sha256(data).hexdigest()
    doc = json.loads(resources.files("miketalk").joinpath(f"data/{PROVENANCE}").read_text())
    assert doc["digest"] == model.digest
    assert len(doc["corpora"]) >= 2 and all(c["frames"] > 0 for c in doc["corpora"].values())
    assert model.weights.shape[2] == len(GEOMETRY) and len(model.variants) >= 2
    assert set(doc["variants"]) == set(model.variants)
    phones, times, sound = _clip(np.random.default_rng(0))
    every = model.every_variant(phones, times, VisemeTable(), sound)
    assert len(every) == len(model.variants)
    for v, shared in enumerate(every):
        assert shared.shape == (len(times), len(GEOMETRY))
        assert np.isfinite(shared).all() and shared.std(axis=0).min() > 0
        np.testing.assert_array_equal(shared, model.predict(phones, times, VisemeTable(), sound, v))


def _mouths(opening: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Grey 94x72 regions of a dark mouth between lighter lips, opening pixels tall
    (lips parting about row 36) and width wide, on textured skin."""
    rng = np.random.default_rng(5)
    skin = 150 + 20 * rng.standard_normal((72, 94))
    skin = np.clip(skin, 0, 255)
    rows, cols = np.mgrid[0:72, 0:94]
    out = []
    for o, w in zip(opening, width, strict=True):
        image = skin.copy()
        lips = (np.abs(cols - 47) < w / 2) & (np.abs(rows - 36) < o / 2 + 6)
        image[lips] = 110
        image[(np.abs(cols - 47) < w / 2 - 4) & (np.abs(rows - 36) < o / 2)] = 30
        out.append(image)
    return np.stack(out)


def test_the_geometry_measures_how_far_the_lips_part() -> None:
    """A mouth opening and closing (and widening) in drawn regions: the measured opening
    follows the drawn one, and the width the drawn width."""
    t = np.arange(40)
    opening = 2 + 8 * (0.5 + 0.5 * np.sin(t / 3))
    width = 50 + 6 * np.cos(t / 5)
    geometry = mouth_geometry(_mouths(opening, width), np.zeros(len(t)))
    assert geometry.shape == (len(t), len(GEOMETRY))
    assert np.corrcoef(geometry[:, 0], opening)[0, 1] > 0.9
    assert np.corrcoef(geometry[:, 1], width)[0, 1] > 0.8
    assert np.polyfit(opening, geometry[:, 0], 1)[0] > 0  # parting is a larger opening


@pytest.mark.parametrize(("lag", "variant"), [(-2, 0), (0, 1), (2, 2)])
def test_the_adaptation_finds_a_persons_lag_variant_and_map(lag: int, variant: int) -> None:
    """His geometry is a linear map of one variant of the pooled trajectory read ``lag``
    frames later, plus noise: the adaptation finds the variant and the lag and predicts
    held-out clips."""
    rng = np.random.default_rng(2)
    table = VisemeTable()
    pooled = _pooled(table, rng, variants=3)
    mixing = rng.standard_normal((3, 3))
    clips = [_clip(rng) for _ in range(10)]
    noise = [0.05 * rng.standard_normal((len(t), 3)) for _, t, _ in clips]
    coords = [
        pooled.predict(p, t + lag / FPS, table, r, variant) @ mixing + e
        for (p, t, r), e in zip(clips, noise, strict=True)
    ]
    data = TrainingSet(
        tuple(c[0] for c in clips), tuple(c[1] for c in clips), tuple(coords),
        tuple(c[2] for c in clips),
    )  # fmt: skip
    held: dict = {}
    geometry = np.concatenate(coords)
    adapted, report = fit_pooled(data, table, geometry, pooled=pooled, predictions=held)
    assert report["lag"] == lag and report["variant"] == f"v{variant}"
    assert min(report["cv_r2"]) > 0.8
    assert sorted(held) == list(range(10))
    p, t, r = clips[3]
    np.testing.assert_allclose(adapted.predict(p, t, table, r), held[3], atol=0.2)
    arrays, settings = to_arrays(adapted)
    assert settings["lag"] == pytest.approx(lag / FPS) and settings["variant"] == variant
    # a face adapted to another pooled model than the package's has no pooled trajectory
    assert from_arrays(arrays, settings) is None


def test_a_recording_is_drawn_along_the_trajectory_the_build_chose() -> None:
    models = {"window": object(), "heard": object(), "pooled": object()}
    face = TrainedFace(None, models, "window", SelectionSettings(), VisemeTable(), {})
    assert face.kind_for(None, recorded=True) == "heard"
    chose = TrainedFace(None, models, "window", SelectionSettings(), VisemeTable(),
                        {"recording": "pooled"})  # fmt: skip
    assert chose.kind_for(None, recorded=True) == "pooled"
    assert chose.kind_for(None, recorded=False) == "window"
    assert chose.kind_for("heard", recorded=True) == "heard"


def test_the_pooled_trajectory_needs_a_recording() -> None:
    with pytest.raises(SettingError, match="pooled trajectory"):
        resolve_lipsync_model(None, available=("trained",), trajectory="pooled", recorded=False)
    model = resolve_lipsync_model(None, available=("trained",), trajectory="pooled", recorded=True)
    assert model == "trained"
