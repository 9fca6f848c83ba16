"""Learned coarticulation (dominance fit, weights) and the N-way morph that draws it."""

from __future__ import annotations

import json
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.draw.coarticulation import (
    CoarticulationParams,
    TrainingClip,
    dominance_weights,
    fit,
    frame_weights,
    predict_trajectory,
    read_params,
    write_params,
)
from miketalk.draw.learned import render_learned, render_model_learned
from miketalk.errors import MiketalkError
from miketalk.flow import pair_path, write_flow_pair
from miketalk.lipsync.timeline import Keyframe, keyframes, plan
from miketalk.media.images import write_png
from miketalk.model.face import Model
from miketalk.model.write import build_model, write_coarticulation
from miketalk.render.morph import Morpher
from miketalk.render.multimorph import MultiMorpher
from miketalk.speech import Phone
from miketalk.visemes import VISEMES, VisemeTable

# ---------------------------------------------------------------------------
# the dominance model and its fit
# ---------------------------------------------------------------------------

TRUE_MAGNITUDE = {"p": 3.0, "aa": 1.0, "t": 0.4, "#": 1.5}
TRUE_RATE = {"p": 30.0, "aa": 10.0, "t": 20.0, "#": 6.0}
TARGETS = {
    "p": np.array([-4.0, 1.0, 0.5]),
    "aa": np.array([6.0, -1.0, 2.0]),
    "t": np.array([1.0, 3.0, -2.0]),
    "#": np.array([-1.0, -2.0, -1.0]),
}


def synthetic_clips(
    params: CoarticulationParams, *, n_clips: int, seed: int, noise: float
) -> list[TrainingClip]:
    """Random phone sequences whose 'real' trajectory is the model's own plus noise."""
    rng = np.random.default_rng(seed)
    names = list(TARGETS)
    clips = []
    for c in range(n_clips):
        t, keys = 0.0, []
        for i in range(14):
            duration = rng.uniform(0.04, 0.2)
            keys.append(Keyframe(names[rng.integers(len(names))], t + duration / 2, i, 0.5))
            t += duration
        times = np.arange(int(t * 25)) / 25.0
        real = predict_trajectory(keys, times, params, TARGETS)
        real = real + rng.normal(0.0, noise, real.shape) + rng.normal(0, 5.0, 3)  # clip offset
        clips.append(TrainingClip(f"c{c}", (), tuple(keys), 25.0, real))
    return clips


def test_fit_recovers_known_magnitudes_rates_and_lead() -> None:
    truth = CoarticulationParams(TRUE_MAGNITUDE, TRUE_RATE, lead=0.04)
    clips = synthetic_clips(truth, n_clips=30, seed=1, noise=0.05)
    fitted = fit(clips, TARGETS, leads=(0.0, 0.02, 0.04, 0.06), prior_strength=1e-6)
    assert fitted.lead == pytest.approx(0.04)
    # the magnitudes are known up to a common factor (the weights are normalized)
    scale = fitted.magnitude["aa"] / TRUE_MAGNITUDE["aa"]
    for v in TARGETS:
        assert fitted.magnitude[v] / scale == pytest.approx(TRUE_MAGNITUDE[v], rel=0.1), v
        assert fitted.rate[v] == pytest.approx(TRUE_RATE[v], rel=0.1), v
    assert fitted.fit["loss"] < 0.01 < fitted.fit["loss_prior"]


def test_fit_is_better_than_the_prior_and_keeps_unseen_visemes_at_the_prior() -> None:
    truth = CoarticulationParams(TRUE_MAGNITUDE, TRUE_RATE)
    clips = synthetic_clips(truth, n_clips=6, seed=2, noise=0.3)
    targets = {**TARGETS, "k": np.zeros(3)}
    fitted = fit(clips, targets, leads=(0.0,), prior_rate=12.0)
    assert fitted.fit["loss"] < fitted.fit["loss_prior"]
    assert fitted.magnitude["k"] == 1.0
    assert fitted.rate["k"] == pytest.approx(12.0)
    assert fitted.fit["frames_per_viseme"]["k"] == 0


def test_weights_sum_to_one_and_rendered_weights_are_truncated() -> None:
    table = VisemeTable()
    names = ["pau", "hh", "ax", "l", "ow", "w", "er", "l", "d", "pau"]
    t, phones = 0.0, []
    for i, name in enumerate(names):
        duration = 0.3 if name == "pau" else 0.05 + 0.02 * (i % 3)
        phones.append(Phone(name, t, t + duration))
        t += duration
    timeline = plan(phones, table, fps=30, duration=t)
    params = CoarticulationParams.prior(table.visemes, max_visemes=3, min_weight=0.1)
    _, weights = dominance_weights(timeline.keyframes, [f.time for f in timeline.frames], params)
    assert np.allclose(weights.sum(axis=1), 1.0)
    assert (weights >= 0).all()
    rows = frame_weights(timeline, params)
    assert len(rows) == len(timeline.frames)
    assert any(len(row) == 3 for row in rows) and any(len(row) == 1 for row in rows)
    for row in rows:
        assert 1 <= len(row) <= 3
        assert sum(w for _, w in row) == pytest.approx(1.0)
        assert all(w >= 0.1 for _, w in row)
        assert len({v for v, _ in row}) == len(row)


def test_a_short_phone_is_undershot_and_a_long_one_reached() -> None:
    params = CoarticulationParams.prior(["p", "aa"], rate=15.0)
    short = [Keyframe("aa", 0.1, 0, 0.5), Keyframe("p", 0.14, 1, 0.5), Keyframe("aa", 0.18, 2, 0.5)]
    long = [Keyframe("aa", 0.1, 0, 0.5), Keyframe("p", 0.4, 1, 0.5), Keyframe("aa", 0.7, 2, 0.5)]
    _, w_short = dominance_weights(short, [0.14], params)
    _, w_long = dominance_weights(long, [0.4], params)
    assert w_short[0, 1] < 0.5  # p (second viseme) never dominates a 40 ms phone
    assert w_long[0, 1] > 0.95


def test_params_round_trip_and_a_model_without_them_is_named(tmp_path: Path) -> None:
    params = CoarticulationParams(
        TRUE_MAGNITUDE, TRUE_RATE, lead=0.02, fit={"loss": 1.5, "clips": 3}
    )
    path = tmp_path / "coarticulation.json"
    assert write_params(params, path) == path
    assert read_params(path) == params
    doc = json.loads(path.read_text())
    doc["rate"]["p"] = -1
    path.write_text(json.dumps(doc))
    with pytest.raises(MiketalkError, match="rate must be positive"):
        read_params(path)
    with pytest.raises(MiketalkError, match="cannot read"):
        read_params(tmp_path / "elsewhere.json")


# ---------------------------------------------------------------------------
# the N-way morph
# ---------------------------------------------------------------------------

SIZE = 64


def smooth_texture(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    noise = rng.random((SIZE // 8, SIZE // 8, 3))
    image = cv2.resize(noise, (SIZE * 2, SIZE * 2), interpolation=cv2.INTER_CUBIC)
    return np.clip(image * 255, 0, 255).astype(np.float32)


def shifts() -> dict[str, np.ndarray]:
    """Each viseme: the texture moved by a known sub-pixel displacement."""
    rng = np.random.default_rng(5)
    return {v: rng.uniform(-3.0, 3.0, 2).astype(np.float32) for v in VISEMES}


def shifted(base: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``base(p - d)`` cut to SIZE x SIZE from the middle."""
    m = np.float32([[1, 0, d[0] - SIZE / 2], [0, 1, d[1] - SIZE / 2]])
    out = cv2.warpAffine(base, m, (SIZE, SIZE), flags=cv2.INTER_CUBIC)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def exact_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """16 visemes, each the texture shifted; the true (constant) flows between them."""
    root = tmp_path_factory.mktemp("exact")
    base, d = smooth_texture(0), shifts()
    paths = {}
    for i, v in enumerate(VISEMES):
        paths[v] = root / "src" / f"{i}.png"
        paths[v].parent.mkdir(exist_ok=True)
        write_png(paths[v], shifted(base, d[v]))
    flows = root / "flows"
    flows.mkdir()
    for i, a in enumerate(VISEMES):
        for b in VISEMES[i + 1 :]:
            # a(p) = base(p - d_a) = b(p + d_b - d_a)
            forward = np.broadcast_to(d[b] - d[a], (SIZE, SIZE, 2)).copy()
            write_flow_pair(
                pair_path(flows, a, b), forward, -forward, source=a, target=b, estimator="true"
            )
    return build_model(root / "model", images=paths, flows_dir=flows, estimator="true", settings={})


def test_two_weights_are_the_papers_morph_byte_for_byte(exact_model: Path) -> None:
    with Model(exact_model) as model:
        morpher = MultiMorpher(model)
        a, b = "p", "aa"
        forward, backward = model.flows.flow(a, b), model.flows.flow(b, a)
        paper = Morpher(model.image(a), model.image(b), forward, backward)
        for wa, wb in ((0.7, 0.3), (0.25, 0.75), (0.5, 0.5), (0.9, 0.1)):
            alpha = wb / (wa + wb)
            assert np.array_equal(morpher.frame([(a, wa), (b, wb), ("t", 0.0)]), paper.frame(alpha))
        assert np.array_equal(morpher.frame([(a, 1.0), (b, 0.0)]), model.image(a))


def test_three_visemes_reach_the_blended_shape(exact_model: Path) -> None:
    base, d = smooth_texture(0), shifts()
    with Model(exact_model) as model:
        morpher = MultiMorpher(model)
        weights = [("p", 0.5), ("aa", 0.3), ("t", 0.2)]
        frame = morpher.frame(weights)
        target = shifted(base, sum(w * d[v] for v, w in weights))
        first_order = MultiMorpher(model, inverse_iterations=0).frame(weights)
    inner = (slice(6, -6), slice(6, -6))
    error = np.abs(frame.astype(float) - target)[inner]
    # a 1-pixel miss on this texture costs far more than this
    assert error.mean() < 1.5
    wrong = shifted(base, d["p"])  # the reference viseme alone
    assert np.abs(wrong.astype(float) - target)[inner].mean() > 3 * error.mean()
    # constant flows: the first-order inverse is already exact
    assert np.abs(first_order.astype(float) - frame).max() <= 1


def test_bad_weights_are_refused(exact_model: Path) -> None:
    with Model(exact_model) as model:
        morpher = MultiMorpher(model)
        for bad in ([], [("p", 0.0)], [("p", -0.1), ("aa", 1.1)], [("p", 0.5), ("p", 0.5)]):
            with pytest.raises(MiketalkError):
                morpher.frame(bad)
        with pytest.raises(MiketalkError, match="no viseme"):
            morpher.frame([("nope", 1.0), ("p", 1.0)])


def test_render_learned_draws_every_frame_the_same_with_any_workers(exact_model: Path) -> None:
    table = VisemeTable()
    names = ["pau", "b", "ih", "n", "b", "l", "uw", "pau"]
    phones = [Phone(n, 0.08 * i, 0.08 * (i + 1)) for i, n in enumerate(names)]
    timeline = plan(phones, table, fps=25, duration=0.64)
    params = CoarticulationParams.prior(table.visemes)
    assert len(keyframes(phones, table)) == len(timeline.keyframes)
    with Model(exact_model) as model:
        one = list(render_learned(model, timeline, params, workers=1))
        two = list(render_learned(model, timeline, params, workers=2))
    assert len(one) == len(timeline.frames)
    assert all(np.array_equal(x, y) for x, y in zip(one, two, strict=True))
    assert any(not np.array_equal(one[0], frame) for frame in one)


def test_the_evaluation_renderer_reads_the_models_own_parameters(
    exact_model: Path, tmp_path: Path
) -> None:
    import shutil

    directory = tmp_path / "model"
    shutil.copytree(exact_model, directory)
    table = VisemeTable()
    phones = [Phone(n, 0.1 * i, 0.1 * (i + 1)) for i, n in enumerate(["pau", "m", "aa", "pau"])]
    timeline = plan(phones, table, fps=25, duration=0.4)
    params = CoarticulationParams.prior(table.visemes, rate=25.0, lead=0.02)
    with Model(directory) as model:
        with pytest.raises(MiketalkError, match="no learned coarticulation"):
            list(render_model_learned(model, timeline))
        write_coarticulation(directory, params)
        got = list(render_model_learned(model, timeline))
        want = list(render_learned(model, timeline, params))
    assert all(np.array_equal(x, y) for x, y in zip(got, want, strict=True))


# ---------------------------------------------------------------------------
# the motion of learned frames
# ---------------------------------------------------------------------------


def _cost(a: str, b: str) -> float:
    return float(abs(ord(a[0]) - ord(b[0])) + len(a) * len(b))


def test_weights_step_on_one_transition_is_the_papers_step() -> None:
    from miketalk.lipsync.motion import weights_step

    for before, after in ((0.2, 0.5), (0.9, 0.1), (0.0, 1.0)):
        got = weights_step([("p", 1 - before), ("aa", before)], [("p", 1 - after), ("aa", after)],
                           _cost)  # fmt: skip
        assert got == pytest.approx(abs(after - before) * _cost("p", "aa"))
    assert weights_step([("p", 0.3), ("aa", 0.7)], [("aa", 0.7), ("p", 0.3)], _cost) == 0.0


def test_weights_step_is_the_least_transport_cost() -> None:
    """Against a linear program over every split, for frames of up to three visemes each."""
    from scipy.optimize import linprog

    from miketalk.lipsync.motion import weights_step

    rng = np.random.default_rng(3)
    names = ["p", "aa", "t", "f", "ii", "w"]
    for _ in range(300):
        a = rng.choice(names, rng.integers(1, 4), replace=False)
        b = rng.choice(names, rng.integers(1, 4), replace=False)
        wa, wb = rng.dirichlet(np.ones(len(a))), rng.dirichlet(np.ones(len(b)))
        cost = np.array([[_cost(u, v) if u != v else 0.0 for v in b] for u in a])
        n, m = cost.shape
        rows = np.zeros((n + m, n * m))
        for i in range(n):
            rows[i, i * m : (i + 1) * m] = 1
        for j in range(m):
            rows[n + j, j::m] = 1
        want = linprog(cost.ravel(), A_eq=rows[:-1], b_eq=np.concatenate([wa, wb])[:-1],
                       bounds=(0, None), method="highs").fun  # fmt: skip
        got = weights_step(list(zip(a, wa, strict=True)), list(zip(b, wb, strict=True)),
                           lambda u, v: 0.0 if u == v else _cost(u, v))  # fmt: skip
        assert got == pytest.approx(want, abs=1e-9)


def test_steps_measured_sentence_by_sentence_are_those_of_the_whole() -> None:
    """A text's steps measured as its sentences are drawn (StepMeter) are those of every
    frame's weights and states kept to the end, the steps across the sentences' edges
    included; and the meter holds no frame's weights but the last."""
    import tracemalloc

    from miketalk.lipsync.motion import StepMeter, measure
    from miketalk.lipsync.timeline import FrameSample, Timeline

    rng = np.random.default_rng(5)

    def row() -> tuple:
        names = rng.choice(["p", "t", "f", "ii"], rng.integers(1, 4), replace=False)
        w = rng.dirichlet(np.ones(len(names))).tolist()
        return tuple(zip(names.tolist(), w, strict=True))

    weights = [row() for _ in range(120)]
    weights[36], weights[37] = (("aa", 1.0),), (("w", 1.0),)  # the largest step: an edge
    exposures = [[w] if k == 37 or rng.random() < 0.6 else [row(), w]
                 for k, w in enumerate(weights)]  # fmt: skip
    states = [s for exposure in exposures for s in exposure]
    timeline = Timeline(30.0, 4.0, (), (), (), tuple(FrameSample(i, i / 30, 0, 0.0)
                                                     for i in range(120)))  # fmt: skip
    edges = (0, 37, 80, 120)
    for with_states in (True, False):
        meter = StepMeter(_cost)
        for a, b in pairwise(edges):
            part = [s for exposure in exposures[a:b] for s in exposure] if with_states else None
            meter.add(weights[a:b], part)
        whole = measure(timeline, _cost, natural_duration=4.0, weights=weights,
                        states=states if with_states else None)  # fmt: skip
        assert measure(timeline, _cost, natural_duration=4.0, steps=meter) == whole
        assert whole.largest_frame_motion_px == _cost("aa", "w")
        assert whole.morphs == (len(states) if with_states else len(weights))
    meter, held = StepMeter(_cost), []
    tracemalloc.start()
    for n in (400, 600):  # 8,000 frames (Python's and numpy's own free lists fill), 12,000
        for _ in range(n):
            meter.add([row() for _ in range(20)])
        held.append(tracemalloc.get_traced_memory()[0])
    tracemalloc.stop()
    assert meter.frames == 20_000 and held[1] - held[0] < 20_000  # weights: 300 bytes a frame


def test_one_blas_thread_holds_blas_to_one_thread_and_the_fit_is_the_same() -> None:
    from threadpoolctl import threadpool_info, threadpool_limits

    from miketalk.workers import one_blas_thread

    truth = CoarticulationParams(TRUE_MAGNITUDE, TRUE_RATE)
    clips = synthetic_clips(truth, n_clips=8, seed=3, noise=0.05)
    with threadpool_limits(limits=2, user_api="blas"):
        two = fit(clips, TARGETS, leads=(0.0, 0.04))
        with one_blas_thread():
            blas = [i for i in threadpool_info() if i["user_api"] == "blas"]
            assert blas and all(i["num_threads"] == 1 for i in blas)
            one = fit(clips, TARGETS, leads=(0.0, 0.04))
        assert all(i["num_threads"] == 2 for i in threadpool_info() if i["user_api"] == "blas")
    assert one.magnitude == two.magnitude and one.rate == two.rate and one.lead == two.lead


def test_a_blend_drawn_in_a_region_is_the_whole_frames_there(exact_model: Path) -> None:
    """Three or more visemes drawn only in a region (what compositing reads): byte for byte
    the whole frame's pixels there, with and without the median, at the frame's edges too;
    the rest is the reference viseme's image."""
    rng = np.random.default_rng(3)
    with Model(exact_model) as model:
        for median in (True, False):
            morpher = MultiMorpher(model)
            morpher.median = median
            for region in ((10, 12, 40, 50), (0, 0, 20, 64), (30, 40, 64, 64), (5, 5, 6, 7)):
                x0, y0, x1, y1 = region
                chosen = rng.choice(len(VISEMES), size=int(rng.integers(3, 6)), replace=False)
                weights = [(VISEMES[i], float(rng.random() + 0.05)) for i in chosen]
                whole = morpher.frame(weights)
                part = morpher.frame(weights, region=region)
                assert np.array_equal(part[y0:y1, x0:x1], whole[y0:y1, x0:x1])
                reference = max(weights, key=lambda item: item[1])[0]
                outside = np.ones(whole.shape[:2], bool)
                outside[y0:y1, x0:x1] = False
                assert np.array_equal(part[outside], model.image(reference)[outside])
