"""Flow estimators, warping, concatenation and the mixed strategy against analytic ground truth."""

from __future__ import annotations

import pickle

import cv2
import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.flow import (
    ESTIMATORS,
    backward_warp,
    bergen_flow,
    concat_flows,
    concatenate_down,
    concatenate_down_flows,
    concatenate_up,
    concatenate_up_flows,
    get_estimator,
    mixed_flow,
)
from miketalk_lab.evaluation.flow_error import endpoint_error


def _texture(shape: tuple[int, int], seed: int = 0, sigma: float = 1.5) -> np.ndarray:
    """Seeded smooth noise in [0, 1], float32."""
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.standard_normal(shape).astype(np.float32), (0, 0), sigma)
    return (noise - noise.min()) / (noise.max() - noise.min())


def _sin_flow_at(
    x: np.ndarray,
    y: np.ndarray,
    shape: tuple[int, int],
    amplitude: float,
    periods: float = 2.0,
    phase: float = 0.0,
) -> np.ndarray:
    """A smooth flow evaluated at any points: dx varies with y, dy with x, sinusoidally."""
    h, w = shape
    return np.stack(
        [
            amplitude * np.sin(2 * np.pi * periods * y / h + phase),
            amplitude * np.cos(2 * np.pi * periods * x / w + phase),
        ],
        axis=-1,
    ).astype(np.float32)


def _sin_flow(
    shape: tuple[int, int], amplitude: float, periods: float = 2.0, phase: float = 0.0
) -> np.ndarray:
    """:func:`_sin_flow_at` on the pixel grid: an (H, W, 2) flow field."""
    y, x = np.mgrid[: shape[0], : shape[1]].astype(np.float64)
    return _sin_flow_at(x, y, shape, amplitude, periods, phase)


def _sin_pair(
    shape: tuple[int, int] = (256, 256), amplitude: float = 4.0, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, true flow A->B) with A(p) = B(p + flow(p)) exactly (bilinear)."""
    b = _texture(shape, seed)
    flow = _sin_flow(shape, amplitude)
    return backward_warp(b, flow), b, flow


@pytest.fixture(scope="module")
def sin_pair() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return _sin_pair()


# Mean endpoint error bounds on the 256x256, 4-pixel sinusoidal pair (measured
# values in the comments, single thread, about 2x margin).
EPE_BOUNDS = {
    "bergen": 0.12,  # 0.057
    "dis_ultrafast": 2.0,  # 1.12
    "dis_fast": 1.8,  # 0.94
    "dis_medium": 0.45,  # 0.22
    "farneback": 0.6,  # 0.29
    "deepflow": 0.15,  # 0.065
    "tvl1": 0.25,  # 0.127
}


def test_every_registered_estimator_has_a_bound():
    assert set(EPE_BOUNDS) == set(ESTIMATORS)


@pytest.mark.parametrize("name", sorted(EPE_BOUNDS))
def test_estimator_recovers_sinusoidal_flow(name, sin_pair):
    a, b, true_flow = sin_pair
    flow = get_estimator(name)(a, b)
    assert flow.shape == true_flow.shape and flow.dtype == np.float32
    assert endpoint_error(flow, true_flow)["mean_epe"] < EPE_BOUNDS[name]


def test_bergen_interior_is_subpixel_accurate(sin_pair):
    a, b, true_flow = sin_pair
    interior = np.zeros(a.shape, bool)
    interior[12:-12, 12:-12] = True
    scores = endpoint_error(bergen_flow(a, b), true_flow, interior)
    assert scores["mean_epe"] < 0.07  # measured 0.032
    assert scores["pct_over_1px"] == 0.0


def test_bergen_uint8_rgb_and_float_agree(sin_pair):
    a, b, true_flow = sin_pair
    to_rgb8 = lambda g: np.repeat(np.rint(g * 255).astype(np.uint8)[..., None], 3, axis=2)  # noqa: E731
    flow8 = bergen_flow(to_rgb8(a), to_rgb8(b))
    flow64 = bergen_flow(a.astype(np.float64), b.astype(np.float64))
    assert endpoint_error(flow8, true_flow)["mean_epe"] < 0.15
    np.testing.assert_array_equal(flow64, bergen_flow(a, b))


def test_bergen_is_deterministic_across_thread_counts(sin_pair):
    a, b, _ = sin_pair
    before = cv2.getNumThreads()
    try:
        cv2.setNumThreads(1)
        one = bergen_flow(a, b)
        cv2.setNumThreads(4)
        four = bergen_flow(a, b)
    finally:
        cv2.setNumThreads(before)
    np.testing.assert_array_equal(one, four)
    np.testing.assert_array_equal(one, bergen_flow(a, b))


def test_zero_motion_gives_zero_flow():
    image = _texture((96, 128), seed=3)
    assert np.array_equal(bergen_flow(image, image), np.zeros((96, 128, 2), np.float32))
    for name in ESTIMATORS:
        if name == "tvl1":  # slow and already covered above; its zero flow is not exact
            continue
        flow = get_estimator(name)(image, image)
        assert np.abs(flow).mean() < 0.05, name


@pytest.mark.parametrize("size", [128, 256])
@pytest.mark.parametrize("levels", [1, 2, 3, 4, 5, 6])
def test_bergen_levels(size, levels):
    b = _texture((size, size), seed=1)
    shift = np.zeros((size, size, 2), np.float32)
    shift[..., 0], shift[..., 1] = 0.6, -0.4  # within one pixel: every depth must manage
    a = backward_warp(b, shift)
    flow = bergen_flow(a, b, levels=levels)
    inner = np.s_[8:-8, 8:-8]
    assert np.isfinite(flow).all()
    assert endpoint_error(flow[inner], shift[inner])["mean_epe"] < 0.05


def test_bergen_needs_levels_for_large_motion():
    b = _texture((128, 128), seed=2)
    shift = np.zeros((128, 128, 2), np.float32)
    shift[..., 0] = 9.0
    a = backward_warp(b, shift)
    inner = np.s_[8:-8, 8:-20]
    deep = bergen_flow(a, b, levels=5)
    assert endpoint_error(deep[inner], shift[inner])["mean_epe"] < 0.1


def test_bad_inputs_raise():
    image = _texture((32, 40))
    with pytest.raises(MiketalkError, match=r"image_b"):
        bergen_flow(image, image[:, :-1])
    with pytest.raises(MiketalkError, match=r"image_b.*dtype"):
        bergen_flow(image, image.astype(np.float64))
    nan = image.copy()
    nan[3, 4] = np.nan
    with pytest.raises(MiketalkError, match=r"image_a.*NaN"):
        bergen_flow(nan, image)
    with pytest.raises(MiketalkError, match=r"image_a"):
        bergen_flow(image[..., None].repeat(4, axis=2), image[..., None].repeat(4, axis=2))
    with pytest.raises(MiketalkError, match=r"image_a.*dtype"):
        bergen_flow(image.astype(np.int32), image.astype(np.int32))
    for name in ("dis_fast", "farneback", "deepflow"):
        with pytest.raises(MiketalkError, match=r"image_b"):
            get_estimator(name)(image, image[:-1])


def test_registry_errors_name_the_problem():
    with pytest.raises(MiketalkError, match=r"known estimators: bergen, dis_ultrafast"):
        get_estimator("lucas")
    with pytest.raises(MiketalkError, match=r"no setting 'level'.*levels"):
        get_estimator("bergen", level=3)
    with pytest.raises(MiketalkError, match=r"levels"):
        get_estimator("bergen", levels=0)
    with pytest.raises(MiketalkError, match=r"preset"):
        get_estimator("dis_fast", preset="slow")
    # values OpenCV would crash on (DIS patch_stride=0) or answer with NaN (winsize=0)
    with pytest.raises(MiketalkError, match=r"patch_stride"):
        get_estimator("dis_medium", patch_stride=0)
    with pytest.raises(MiketalkError, match=r"winsize"):
        get_estimator("farneback", winsize=0)
    with pytest.raises(MiketalkError, match=r"scale_step"):
        get_estimator("tvl1", scale_step=1.0)
    est = get_estimator("bergen", levels=4)
    assert est.settings["levels"] == 4 and ESTIMATORS["bergen"].settings["levels"] == 6
    assert pickle.loads(pickle.dumps(est)) == est  # for process pools


# --- backward warp (Fig. 9) ---------------------------------------------------------------


def test_backward_warp_of_constant_flow_is_exact():
    rng = np.random.default_rng(5)
    image = rng.random((20, 30)).astype(np.float32)
    flow = np.zeros((20, 30, 2), np.float32)
    flow[..., 0], flow[..., 1] = 3.0, -2.0
    out = backward_warp(image, flow)
    np.testing.assert_array_equal(out[2:, :-3], image[:-2, 3:])
    # a flow field is warped channel by channel, exactly, like an image
    field = rng.random((20, 30, 2)).astype(np.float32)
    np.testing.assert_array_equal(backward_warp(field, flow)[2:, :-3], field[:-2, 3:])
    # bilinear interpolation is exact on a linear ramp, for fractional shifts too
    ramp = np.add.outer(np.arange(20) * 0.5, np.arange(30) * 0.25).astype(np.float32)
    flow[..., 0], flow[..., 1] = 0.375, 0.625
    expected = ramp + 0.375 * 0.25 + 0.625 * 0.5
    np.testing.assert_allclose(backward_warp(ramp, flow)[:-1, :-1], expected[:-1, :-1], atol=1e-5)


def test_backward_warp_replicates_borders_and_keeps_uint8():
    image = np.arange(12, dtype=np.uint8).reshape(3, 4)
    flow = np.zeros((3, 4, 2), np.float32)
    flow[..., 0] = -10.0
    out = backward_warp(image, flow)
    assert out.dtype == np.uint8
    np.testing.assert_array_equal(out, np.repeat(image[:, :1], 4, axis=1))
    with pytest.raises(MiketalkError, match=r"flow"):
        backward_warp(image, flow[:2])


# --- concatenation (Eq. 11, Figs. 10-11) --------------------------------------------------


def test_concat_flows_matches_analytic_composition():
    shape = (96, 112)
    y, x = np.mgrid[: shape[0], : shape[1]].astype(np.float64)
    first = _sin_flow_at(x, y, shape, 2.5, periods=1.0, phase=0.3)
    second = _sin_flow(shape, 1.5, periods=1.0, phase=1.1)
    # C_ac(p) = C_ab(p) + C_bc(p + C_ab(p)), with C_bc evaluated exactly at the moved points
    expected = first + _sin_flow_at(
        x + first[..., 0], y + first[..., 1], shape, 1.5, periods=1.0, phase=1.1
    )
    got = concat_flows(first, second)
    inner = np.s_[4:-4, 4:-4]  # away from the borders, where p + first(p) stays inside
    assert np.abs(got - expected)[inner].max() < 0.01


def test_concat_flows_of_translations_is_their_sum():
    a = np.zeros((10, 12, 2), np.float32)
    b = np.zeros((10, 12, 2), np.float32)
    a[..., 0], a[..., 1] = 1.25, -0.5
    b[..., 0], b[..., 1] = 0.5, 2.0
    np.testing.assert_allclose(concat_flows(a, b), a + b, atol=1e-6)
    with pytest.raises(MiketalkError, match=r"flow_bc"):
        concat_flows(a, b[:, :-1])


def test_concatenation_up_and_down_match_analytic_composition():
    shape = (64, 80)
    phases = [0.4 * k for k in range(5)]
    steps = [_sin_flow(shape, 0.8, periods=1.0, phase=ph) for ph in phases]
    # exact C_0n: follow every pixel through the analytic steps
    y, x = np.mgrid[: shape[0], : shape[1]].astype(np.float64)
    px, py = x.copy(), y.copy()
    for ph in phases:
        d = _sin_flow_at(px, py, shape, 0.8, periods=1.0, phase=ph).astype(np.float64)
        px, py = px + d[..., 0], py + d[..., 1]
    exact = np.stack([px - x, py - y], axis=-1)
    up = concatenate_up_flows(steps)
    down_all = concatenate_down_flows(steps)
    assert len(down_all) == len(steps)
    np.testing.assert_array_equal(down_all[-1], steps[-1])
    inner = np.s_[6:-6, 6:-6]
    for flow in (up, down_all[0]):
        assert np.abs(flow - exact)[inner].max() < 0.03
        assert np.abs(flow - exact)[inner].mean() < 0.005
    assert np.abs(up - down_all[0])[inner].max() < 0.03
    # UP is the left fold of Eq. 11 over the steps
    fold = steps[0]
    for step in steps[1:]:
        fold = concat_flows(fold, step)
    np.testing.assert_array_equal(up, fold)


def test_concatenate_frames_up_and_down_explain_the_last_frame():
    shape = (128, 128)
    texture = _texture(shape, seed=7)
    motion = _sin_flow(shape, 3.0, periods=1.0, phase=0.5)
    frames = [backward_warp(texture, motion * (k / 6)) for k in range(7)]
    est = get_estimator("bergen")
    up = concatenate_up(frames, est)
    down = concatenate_down(frames, est)
    inner = np.s_[10:-10, 10:-10]
    for flow in (up, down):
        residual = np.abs(frames[0] - backward_warp(frames[-1], flow))[inner].mean()
        assert residual < 0.01
    assert np.abs(up - down)[inner].mean() < 0.05
    with pytest.raises(MiketalkError, match=r"at least 2"):
        concatenate_up(frames[:1], est)


# --- mixed strategy (section 5.2) --------------------------------------------------------


def test_mixed_flow_beats_direct_and_full_concatenation():
    shape = (96, 96)
    texture = _texture(shape, seed=11)
    motion = _sin_flow(shape, 1.0, periods=1.0)
    # a recording: frame k is the texture moved by amount[k] * motion; the mouth opens,
    # closes to nearly the start shape at frame 8, and opens again to the end viseme (12)
    amount = [0, 2, 4, 6, 8, 6, 4, 2, 0.5, 2, 4, 6, 8]
    frames = [backward_warp(texture, motion * s) for s in amount]
    start = texture  # the start viseme: amount 0
    # true flow start -> end: start(p) = T(p) = end(q) = T(q + 8 m(q)), so q = p - 8 m(q)
    y, x = np.mgrid[: shape[0], : shape[1]].astype(np.float64)
    qx, qy = x.copy(), y.copy()
    for _ in range(60):  # a contraction: |8 m'| <= 8 * 2 pi / 96 < 1
        m = _sin_flow_at(qx, qy, shape, 1.0, periods=1.0).astype(np.float64)
        qx, qy = x - 8 * m[..., 0], y - 8 * m[..., 1]
    true_flow = np.stack([qx - x, qy - y], axis=-1)
    inner = np.zeros(shape, bool)
    inner[8:-8, 8:-8] = True

    est = get_estimator("bergen", levels=1)  # reaches ~2 pixels: the direct flow fails
    flow, info = mixed_flow(start, frames, 12, est, window=6)
    assert info.candidates == tuple(range(6, 13))
    assert len(info.scores) == len(info.residuals) == 7
    assert info.score == min(info.scores)
    assert 7 <= info.index <= 10  # near the start shape, a few frames before the end
    mixed = endpoint_error(flow, true_flow, inner)["mean_epe"]  # measured 0.33
    direct = endpoint_error(est(start, frames[12]), true_flow, inner)["mean_epe"]  # 7.8
    chain = concatenate_up([start, *frames[1:]], est)
    full = endpoint_error(chain, true_flow, inner)["mean_epe"]  # 0.46
    assert mixed < 0.5 and direct > 3.0 and mixed < full
    # window=0: the direct flow only
    only, info0 = mixed_flow(start, frames, 12, est, window=0)
    assert info0.index == 12 and info0.candidates == (12,)
    np.testing.assert_array_equal(only, est(start, frames[12]))
    # a large charge per concatenated frame pulls j to the end frame
    _, info_far = mixed_flow(start, frames, 12, est, window=4, penalty=10.0)
    assert info_far.index == 12


def test_mixed_flow_rejects_bad_arguments():
    frames = [_texture((32, 32), seed=s) for s in range(4)]
    est = get_estimator("bergen", levels=2)
    with pytest.raises(MiketalkError, match=r"end_index"):
        mixed_flow(frames[0], frames, 4, est)
    with pytest.raises(MiketalkError, match=r"window"):
        mixed_flow(frames[0], frames, 3, est, window=-1)
    with pytest.raises(MiketalkError, match=r"mask"):
        mixed_flow(frames[0], frames, 3, est, mask=np.zeros((32, 32), bool))
    with pytest.raises(MiketalkError, match=r"frames\[2\]"):
        mixed_flow(frames[0], [*frames[:2], frames[2][:-1], frames[3]], 3, est)


# --- bridge strategy (through the recording's rest frames) ------------------------------


def _bridge_recording(tmp_path):
    """A recording of a deforming texture: rest, out to +6, rest, out to -6, rest.

    Frame k is ``T(p + s_k F(p))`` for a smooth field ``F`` (up to 2 px per unit of
    ``s``), so frames a and b correspond by ``q + s_b F(q) = p + s_a F(p)``.
    """
    from miketalk.media.images import write_png

    shape = (96, 96)
    y, x = np.mgrid[: shape[0], : shape[1]].astype(np.float64)
    field = np.stack([2 * np.sin(2 * np.pi * y / 96), np.cos(2 * np.pi * x / 96)], -1)
    ramp = list(np.linspace(0, 6, 7)[1:]) + list(np.linspace(6, 0, 7)[1:])
    s = [0.0] * 5 + ramp + [0.0] * 5 + [-v for v in ramp] + [0.0] * 5
    grey = (_texture(shape, seed=3) * 255).astype(np.float32)
    frames = tmp_path / "frames"
    frames.mkdir()
    for k, sk in enumerate(s):
        image = backward_warp(grey, (sk * field).astype(np.float32))
        write_png(
            frames / f"{k:06d}.png", np.repeat(np.round(image)[..., None], 3, -1).astype(np.uint8)
        )

    def true_flow(a: int, b: int) -> np.ndarray:
        target = np.stack([x, y], -1) + s[a] * field
        q = target.copy()
        for _ in range(60):  # fixed point of q = p + s_a F(p) - s_b F(q); contracts here
            fq = np.stack(
                [2 * np.sin(2 * np.pi * q[..., 1] / 96), np.cos(2 * np.pi * q[..., 0] / 96)], -1
            )
            q = target - s[b] * fq
        return (q - np.stack([x, y], -1)).astype(np.float32)

    return frames, s, true_flow


def test_rest_frames_and_nearest_rest():
    from miketalk.corpus.rest import nearest_rest, rest_frames

    rng = np.random.default_rng(0)
    rest_image = rng.integers(0, 256, (32, 32, 3), dtype=np.uint8)
    moving = [np.roll(rest_image, k, axis=1) for k in range(1, 6)]
    frames = [rest_image] * 3 + moving + [rest_image] * 4 + moving[::-1] + [rest_image] * 3
    rest = rest_frames(frames, 1)
    assert rest.tolist() == [0, 1, 2, 8, 9, 10, 11, 17, 18, 19]
    assert nearest_rest(5, rest) == 2 and nearest_rest(6, rest) == 8
    assert nearest_rest(14, rest) == 11  # 3 frames from 11 and from 17: the earlier
    with pytest.raises(MiketalkError, match="silence_frame"):
        rest_frames(frames, 40)


def test_rest_frames_and_motion_region_are_the_same_measured_in_blocks():
    """A long recording is measured a block of frames (and of pixels) at a time, held as
    grey uint8: the rest frames and the motion region are those of the whole at once."""
    import cv2

    from miketalk.corpus.rest import grey_stack, motion_region, rest_frames

    rng = np.random.default_rng(3)
    rest_image = rng.integers(0, 256, (40, 52, 3), dtype=np.uint8)
    frames = []
    for k in range(37):
        shift = (0, 1, 3, 2, 0, 0)[k % 6]
        frame = rest_image.astype(np.int64) + rng.integers(-3, 4, rest_image.shape)
        frame[12:28, 16:36] = np.roll(rest_image, shift, axis=0)[12:28, 16:36]  # a mouth
        frames.append(np.clip(frame, 0, 255).astype(np.uint8))
    whole = rest_frames(frames, 0, block=len(frames))
    assert 0 in whole and 5 < len(whole) < 30
    for block in (1, 4, 9):
        assert np.array_equal(rest_frames(frames, 0, block=block), whole)
    grey = grey_stack((cv2.cvtColor(f, cv2.COLOR_RGB2GRAY) for f in frames), len(frames))
    assert grey.dtype == np.uint8 and grey.shape == (37, 40, 52)
    as_float = grey.astype(np.float32)
    spread = cv2.GaussianBlur(as_float.std(axis=0), (0, 0), 2.0)
    direct = spread > 0.3 * spread.max()
    assert 0 < direct.sum() < direct.size
    for block in (1, 7, 100_000):
        assert np.array_equal(motion_region(grey, block=block), direct)
        assert np.array_equal(motion_region(as_float, block=block), direct)
    with pytest.raises(MiketalkError, match="no frames"):
        grey_stack(iter(()), 3)
    with pytest.raises(MiketalkError, match="2 frames where 3"):
        grey_stack(iter(grey[:2]), 3)
    with pytest.raises(MiketalkError, match="more than the 3"):
        grey_stack(iter(grey[:4]), 3)


def test_bridge_strategy_joins_far_visemes_through_rest(tmp_path):
    import pandas as pd

    from miketalk.flow import FlowDatabase
    from miketalk.flow.build import build_flow_database

    frames, _, true_flow = _bridge_recording(tmp_path)
    peak_a, peak_b = 5 + 5, 5 + 12 + 5 + 5  # s = +6 and s = -6
    visemes = pd.DataFrame(
        {"viseme": ["#", "A", "B"], "frame": [2, peak_a, peak_b],
         "image": [f"{k:06d}.png" for k in (2, peak_a, peak_b)]}
    )  # fmt: skip
    table = build_flow_database(
        tmp_path / "bridge", visemes=visemes, images_dir=frames, frames_dir=frames,
        estimator="bergen", settings={"levels": 2}, strategy="bridge",
    )  # fmt: skip
    row = table[(table["source"] == "A") & (table["target"] == "B")].iloc[0]
    assert (row["rest_a"], row["rest_b"]) == (4, 21)
    assert row["forward_bridged"] and row["backward_bridged"] and row["forward_chain"] == 12
    inner = (slice(12, -12), slice(12, -12))
    flow = FlowDatabase(tmp_path / "bridge").flow("A", "B")
    truth = true_flow(peak_a, peak_b)  # up to 24 px: far beyond one level's reach
    assert np.abs(truth).max() > 20
    bridged = np.linalg.norm(flow - truth, axis=-1)[inner].mean()  # measured 0.46
    direct = bergen_flow(
        *(cv2.imread(str(frames / f"{k:06d}.png")) for k in (peak_a, peak_b)), levels=2
    )
    assert bridged < 0.7 < 10.0 < np.linalg.norm(direct - truth, axis=-1)[inner].mean()  # 18.7
    back = FlowDatabase(tmp_path / "bridge").flow("B", "A")
    assert np.linalg.norm(back - true_flow(peak_b, peak_a), axis=-1)[inner].mean() < 0.7


# --- chains of flows estimated in a region, computed in its box -------------------------


def _flows_in_box(rng, shape, box, scale, n):
    x, y, w, h = box
    flows = []
    for _ in range(n):
        flow = np.zeros((*shape, 2), np.float32)
        smooth = cv2.GaussianBlur(rng.normal(0, scale * 4, (h, w, 2)).astype(np.float32), (0, 0), 2)
        flow[y : y + h, x : x + w] = smooth + rng.normal(0, scale / 10, (h, w, 2))
        flows.append(flow)
    return flows


@pytest.mark.parametrize("scale", [0.2, 2.0, 15.0])
@pytest.mark.parametrize(
    "box", [(40, 30, 50, 20), (0, 0, 60, 40), (70, 50, 50, 30), (1, 1, 118, 78)]
)
def test_a_chain_of_flows_zero_outside_a_box_is_computed_in_the_box_to_the_bit(scale, box):
    """Concatenation in the support box gives the whole concatenation's numbers (equal
    arrays, not close ones), for small and large flows and boxes at the frame's edges."""
    from miketalk.flow.warp import _remap, warp_in_box

    rng = np.random.default_rng(int(scale * 10) + box[0])
    shape = (80, 120)
    flows = _flows_in_box(rng, shape, box, scale, 6)
    x, y, w, h = box
    warped = warp_in_box(flows[1], flows[0][y : y + h, x : x + w], (x, y))
    assert np.array_equal(warped, _remap(flows[1], flows[0])[y : y + h, x : x + w])
    for image in (
        rng.integers(0, 256, (*shape, 3), dtype=np.uint8),
        rng.integers(0, 256, shape, dtype=np.uint8),
        rng.normal(0, 1, shape).astype(np.float32),
        rng.normal(0, 1, (*shape, 3)).astype(np.float32),
    ):
        warped = warp_in_box(image, flows[0][y : y + h, x : x + w], (x, y))
        assert np.array_equal(warped, _remap(image, flows[0])[y : y + h, x : x + w])
    whole = concatenate_up_flows(flows)
    boxed = concatenate_up_flows(flows, support=box)
    assert np.abs(whole).max() > scale / 2
    assert np.array_equal(boxed, whole)


def test_a_recordings_folds_and_chains_in_its_region_are_those_of_the_whole_frame(tmp_path):
    from miketalk.flow.strategies.base import Recording

    rng = np.random.default_rng(5)
    shape, box = (64, 96), (20, 14, 48, 30)
    forward = np.stack(_flows_in_box(rng, shape, box, 1.5, 12))
    backward = np.stack(_flows_in_box(rng, shape, box, 1.5, 12))
    frames = tmp_path / "frames"
    frames.mkdir()
    cv2.imwrite(str(frames / "000000.png"), np.zeros((*shape, 3), np.uint8))

    def recording(support):
        return Recording(
            estimate=bergen_flow, frames_dir=frames, n_frames=13, consecutive=(forward, backward),
            slots={k: k for k in range(12)}, viseme_frames=(0, 5, 12), support=support,
        )  # fmt: skip

    whole, boxed = recording(None), recording(box)
    whole.frame, boxed.frame = (lambda k: np.zeros((*shape, 3), np.uint8),) * 2
    for start in (0, 5, 12):
        folds = whole.fold_from(start)
        assert folds.keys() == boxed.fold_from(start).keys()
        for end, flow in folds.items():
            assert np.array_equal(boxed.fold_from(start)[end], flow)
    assert np.array_equal(boxed.fold_of_steps(9, 2), whole.fold_of_steps(9, 2))
    steps = boxed.steps(3, 11)
    assert np.array_equal(boxed.chain(steps, 3), whole.chain(steps, 3))


def test_the_mixed_flow_in_a_region_is_the_same_computed_in_its_box():
    """The mixed strategy's window chains (CONCATENATION-DOWN) and its direct-then-chained
    flows, computed in the region's box, are the whole frame's to the bit."""
    from miketalk.flow.mixed import window_chains
    from miketalk.flow.registry import in_region

    shape, box = (72, 96), (18, 12, 56, 44)
    y = np.mgrid[: shape[0], : shape[1]][0].astype(np.float32)
    grey = _texture(shape, seed=7).astype(np.float32)
    frames = []
    for k in range(7):
        flow = np.zeros((*shape, 2), np.float32)
        flow[..., 0] = 0.6 * k * np.sin(2 * np.pi * y / 72)
        frames.append((backward_warp(grey, flow) * 255).astype(np.uint8))
    estimate = in_region(get_estimator("bergen", levels=2), box)
    chains = window_chains(frames, 6, estimate, window=4)
    boxed = window_chains(frames, 6, estimate, window=4, support=box)
    assert len(chains) == 4 and np.abs(chains[0]).max() > 1
    assert all(np.array_equal(a, b) for a, b in zip(chains, boxed, strict=True))
    whole, info = mixed_flow(frames[0], frames, 6, estimate, window=4)
    within, info_within = mixed_flow(frames[0], frames, 6, estimate, window=4, support=box)
    assert np.array_equal(whole, within) and info == info_within
