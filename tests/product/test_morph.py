"""Tests of miketalk.render.morph: forward warp, hole-aware blend, hole filling, median, checks."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.render.morph import Morpher, cross_dissolve, morph, morph_stages
from miketalk.render.splat import HOLE_VALUE, fill_holes_scanline, forward_warp
from miketalk_lab.bench.morph import numpy_morph, scene


def _texture(h: int, w: int, channels: int = 3, seed: int = 0) -> np.ndarray:
    """Smooth random texture in [10, 245] (never the hole colour 0)."""
    rng = np.random.default_rng(seed)
    coarse = rng.random((h // 4 + 1, w // 4 + 1, channels)).astype(np.float32)
    smooth = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_LINEAR).reshape(h, w, channels)
    image = (10 + 235 * smooth).astype(np.uint8)
    return image[..., 0] if channels == 1 else image


def _constant_flow(h: int, w: int, dx: float, dy: float) -> np.ndarray:
    flow = np.empty((h, w, 2), np.float32)
    flow[..., 0], flow[..., 1] = dx, dy
    return flow


def _smooth_flow(h: int, w: int, amplitude: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    coarse = rng.uniform(-amplitude, amplitude, (4, 4, 2)).astype(np.float32)
    return cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)


@pytest.fixture
def pair() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Two textured RGB images with smooth, divergent random flows."""
    h, w = 48, 64
    return (
        _texture(h, w, seed=1),
        _texture(h, w, seed=2),
        _smooth_flow(h, w, 6.0, seed=3),
        _smooth_flow(h, w, 6.0, seed=4),
    )


# --------------------------------------------------------------------- endpoints


@pytest.mark.parametrize("channels", [1, 3])
def test_alpha_endpoints_give_the_input_images(pair, channels):
    image0, image1, flow01, flow10 = pair
    if channels == 1:
        image0, image1 = image0[..., 0].copy(), image1[..., 0].copy()
    morpher = Morpher(image0, image1, flow01, flow10, median=False)
    np.testing.assert_array_equal(morpher.frame(0.0), image0)
    np.testing.assert_array_equal(morpher.frame(1.0), image1)
    assert morpher.frame(0.5).shape == image0.shape


def test_output_shape_and_dtype(pair):
    frame = morph(*pair, 0.3)
    assert frame.shape == pair[0].shape and frame.dtype == np.uint8


# ------------------------------------------------------------------ translation


@pytest.mark.parametrize(("dx", "dy"), [(4, 2), (-6, 4), (3, -1)])
def test_translation_morph_is_the_half_translated_image(dx, dy):
    h, w, m = 64, 80, 8  # m: margin excluded from the comparison
    image0 = _texture(h, w)
    image1 = np.roll(image0, (dy, dx), axis=(0, 1))  # I1(p + d) = I0(p)
    flow01 = _constant_flow(h, w, dx, dy)
    flow10 = _constant_flow(h, w, -dx, -dy)
    # a shift of d/2 rounds half up: floor(d/2 + 0.5)
    half = (int(np.floor(dy / 2 + 0.5)), int(np.floor(dx / 2 + 0.5)))
    expected = np.roll(image0, half, axis=(0, 1))
    inner = np.s_[m:-m, m:-m]
    plain = morph(image0, image1, flow01, flow10, 0.5, median=False)
    np.testing.assert_array_equal(plain[inner], expected[inner])
    final = morph(image0, image1, flow01, flow10, 0.5)
    np.testing.assert_array_equal(final[inner], cv2.medianBlur(expected, 3)[inner])


# ------------------------------------------------------------------------ holes


def _holey_pair() -> tuple[np.ndarray, ...]:
    """A pair whose two warps both expand the centre, so both leave holes in the same places."""
    image0, image1, flow01, _ = scene(96)
    image0, image1 = np.maximum(image0, 10), np.maximum(image1, 10)  # 0 is the hole colour
    return image0, image1, flow01, flow01.copy()


def test_no_hole_is_left_after_filling():
    image0, image1, flow01, flow10 = _holey_pair()
    for alpha in (0.25, 0.5, 0.75):
        stages = morph_stages(image0, image1, flow01, flow10, alpha)
        assert stages.hole0.any() and stages.hole.any()
        assert (stages.blend[stages.hole] == HOLE_VALUE).all()
        assert (stages.filled >= 10).all()
        assert (stages.final >= 10).all()
        frame = morph(image0, image1, flow01, flow10, alpha, median=False)
        np.testing.assert_array_equal(frame, stages.filled)


def test_fill_holes_false_leaves_holes_black():
    image0, image1, flow01, flow10 = _holey_pair()
    stages = morph_stages(image0, image1, flow01, flow10, 0.5)
    frame = morph(image0, image1, flow01, flow10, 0.5, fill_holes=False, median=False)
    assert stages.hole.any()
    assert (frame[stages.hole] == HOLE_VALUE).all()
    assert (frame[~stages.hole] >= 10).all()
    np.testing.assert_array_equal(frame, stages.blend)


def test_median_flag(pair):
    plain = morph(*pair, 0.4, median=False)
    np.testing.assert_array_equal(morph(*pair, 0.4), cv2.medianBlur(plain, 3))


def _hole_in_warp0() -> tuple[np.ndarray, ...]:
    """I0 = 100 and I1 = 200 everywhere; at alpha 0.5 pixel (row 2, col 5) is a hole of warp0."""
    h, w = 5, 10
    image0, image1 = np.full((h, w), 100, np.uint8), np.full((h, w), 200, np.uint8)
    flow01 = np.zeros((h, w, 2), np.float32)
    flow01[2, 5, 0] = 2.0  # moves to column 6 at alpha 0.5, leaving column 5 empty
    return image0, image1, flow01, np.zeros((h, w, 2), np.float32)


def test_hole_aware_blend_takes_the_other_warp():
    image0, image1, flow01, flow10 = _hole_in_warp0()
    warped, hole = forward_warp(image0, flow01, 0.5)
    assert hole[2, 5] and hole.sum() == 1 and warped[2, 5] == HOLE_VALUE
    aware = morph(image0, image1, flow01, flow10, 0.5, fill_holes=False, median=False)
    assert aware[2, 5] == 200  # only warp1 reached it: its value, unblended
    assert (np.delete(aware.ravel(), 2 * 10 + 5) == 150).all()
    naive = morph(
        image0, image1, flow01, flow10, 0.5, hole_aware_blend=False, fill_holes=False, median=False
    )
    assert naive[2, 5] == 100  # Eq. 7 with the hole read as black: 0.5 * 0 + 0.5 * 200
    stages = morph_stages(image0, image1, flow01, flow10, 0.5)
    assert not stages.hole.any() and stages.hole0[2, 5] and not stages.hole1.any()


def test_fill_holes_scanline_interpolates_linearly():
    row = np.array([[0, 10, 0, 0, 40, 0, 0, 0, 0, 80, 0]], np.uint8)
    filled = fill_holes_scanline(row, row == 0)
    np.testing.assert_array_equal(filled, [[10, 10, 20, 30, 40, 48, 56, 64, 72, 80, 80]])


def test_fill_holes_scanline_rounds_half_up_per_channel():
    image = np.zeros((1, 3, 3), np.uint8)
    image[0, 0] = (0, 10, 255)
    image[0, 2] = (1, 20, 0)
    hole = np.array([[False, True, False]])
    np.testing.assert_array_equal(fill_holes_scanline(image, hole)[0, 1], (1, 15, 128))


def test_fill_holes_scanline_empty_rows_use_the_columns():
    image = np.zeros((6, 3), np.uint8)
    image[1] = 10
    image[4] = 40
    image[4, 0] = 70
    hole = np.ones((6, 3), bool)
    hole[1] = hole[4] = False
    filled = fill_holes_scanline(image, hole)
    np.testing.assert_array_equal(filled[:, 1], [10, 10, 20, 30, 40, 40])
    np.testing.assert_array_equal(filled[:, 0], [10, 10, 30, 50, 70, 70])
    all_holes = np.ones((6, 3), bool)
    np.testing.assert_array_equal(fill_holes_scanline(image, all_holes), image)


def test_everything_leaving_the_frame_falls_back_to_a_cross_dissolve():
    image0, image1 = _texture(20, 30, seed=5), _texture(20, 30, seed=6)
    away = _constant_flow(20, 30, 100.0, 0.0)
    frame = morph(image0, image1, away, -away, 0.5, median=False)
    np.testing.assert_array_equal(frame, cross_dissolve(image0, image1, 0.5))


# ------------------------------------------------------------------- collisions


def _collide() -> tuple[np.ndarray, np.ndarray]:
    """Row of 10: sources at columns 2 (+2) and 4 (static) land on column 4; 6 (-2) too."""
    image = np.arange(10, 110, 10, dtype=np.uint8)[None, :].repeat(3, axis=0)
    flow = np.zeros((3, 10, 2), np.float32)
    flow[1, 2, 0] = 2.0
    flow[1, 6, 0] = -2.0
    flow[0, 3, 0], flow[0, 5, 0] = 1.0, -1.0  # a tie in motion on row 0: column 4
    return image, flow


def test_collision_rule_motion_wins_then_scan_order():
    image, flow = _collide()
    warped, hole = forward_warp(image, flow, 1.0)
    assert warped[1, 4] == image[1, 6]  # both movers beat the static pixel; 6 is later
    assert warped[0, 4] == image[0, 5]  # equal motion: the later pixel in scan order
    assert hole[1, 2] and hole[1, 6] and hole[0, 3] and hole[0, 5]
    flow[1, 6, 0] = 0.0
    warped, _ = forward_warp(image, flow, 1.0)
    assert warped[1, 4] == image[1, 2]  # the mover wins over the static pixel
    scan, _ = forward_warp(image, flow, 1.0, collision="scan")
    assert scan[1, 4] == image[1, 4]  # Fig. 6: last write (column 4) wins


def test_deterministic_and_equal_to_the_numpy_reference():
    image0, image1, flow01, flow10 = scene(64, seed=3)
    for collision in ("motion", "scan"):
        morpher = Morpher(image0, image1, flow01, flow10, collision=collision)
        for alpha in (0.0, 0.2, 0.5, 0.9):
            first = morpher.frame(alpha)
            np.testing.assert_array_equal(first, morpher.frame(alpha))
            np.testing.assert_array_equal(
                first, numpy_morph(image0, image1, flow01, flow10, alpha, collision=collision)
            )


@pytest.mark.parametrize("seed", range(6))
def test_random_scenes_equal_the_numpy_reference(seed):
    # odd sizes, grey and RGB, small to huge motions (pixels leaving the frame,
    # many collisions and holes): the C kernel and numpy agree bit for bit
    rng = np.random.default_rng(seed)
    h, w = (int(v) for v in rng.integers(5, 48, 2))
    shape = (h, w) if seed % 2 else (h, w, 3)
    image0 = rng.integers(0, 256, shape, dtype=np.uint8)
    image1 = rng.integers(0, 256, shape, dtype=np.uint8)
    scale = (0.5, 3.0, 20.0)[seed % 3]
    flow01 = (rng.standard_normal((h, w, 2)) * scale).astype(np.float32)
    flow10 = np.round(rng.standard_normal((h, w, 2)) * scale).astype(np.float32)
    for collision in ("motion", "scan"):
        morpher = Morpher(image0, image1, flow01, flow10, collision=collision)
        for alpha in (0.0, 0.25, 1 / 3, 0.5, 0.77, 1.0):
            np.testing.assert_array_equal(
                morpher.frame(alpha),
                numpy_morph(image0, image1, flow01, flow10, alpha, collision=collision),
            )


def test_kernels_reject_buffers_of_the_wrong_layout():
    # the C functions check sizes themselves, so a wrong call cannot read out of bounds
    from miketalk.render import _morph_kernels as kernels

    flow = np.zeros((4, 5, 2), np.float32)
    priority = np.zeros((4, 5), np.float32)
    index, depth = np.zeros((4, 5), np.int32), np.zeros((4, 5), np.float32)
    kernels.splat(flow, priority, 0.5, index, depth)
    with pytest.raises(ValueError, match="priority"):
        kernels.splat(flow, priority[:3], 0.5, index, depth)
    with pytest.raises(ValueError, match="index"):
        kernels.splat(flow, priority, 0.5, index.astype(np.int64), depth)
    with pytest.raises((ValueError, BufferError)):
        kernels.splat(flow[:, ::2], priority[:, ::2], 0.5, index[:, ::2], depth[:, ::2])
    readonly = index.copy()
    readonly.flags.writeable = False
    with pytest.raises((ValueError, BufferError)):
        kernels.splat(flow, priority, 0.5, readonly, depth)
    with pytest.raises(ValueError, match="hole"):
        kernels.fill_holes(np.zeros((4, 5, 3), np.uint8), np.zeros((5, 4), bool))


def test_morpher_matches_morph_and_frames(pair):
    morpher = Morpher(*pair)
    alphas = [0.0, 0.3, 0.6, 1.0]
    for alpha, frame in zip(alphas, morpher.frames(alphas), strict=True):
        np.testing.assert_array_equal(frame, morph(*pair, alpha))


def test_readonly_and_noncontiguous_inputs(pair):
    image0, image1, flow01, flow10 = pair
    expected = morph(*pair, 0.5)
    image0 = image0.copy()
    image0.flags.writeable = False
    flow01 = np.asfortranarray(flow01)
    np.testing.assert_array_equal(morph(image0, image1, flow01, flow10, 0.5), expected)


# ---------------------------------------------------------------- cross dissolve


def test_cross_dissolve():
    a, b = np.full((2, 2, 3), 10, np.uint8), np.full((2, 2, 3), 21, np.uint8)
    np.testing.assert_array_equal(cross_dissolve(a, b, 0.0), a)
    np.testing.assert_array_equal(cross_dissolve(a, b, 1.0), b)
    assert (cross_dissolve(a, b, 0.5) == 16).all()  # 15.5 rounds up


# ----------------------------------------------------------------------- checks


@pytest.mark.parametrize(
    ("change", "name"),
    [
        (lambda a: {**a, "image0": a["image0"].astype(np.float32)}, "image0"),
        (lambda a: {**a, "image1": a["image1"][:, :-1]}, "image1"),
        (lambda a: {**a, "image1": a["image1"][..., 0]}, "image1"),
        (lambda a: {**a, "image0": np.zeros((4, 4, 2), np.uint8)}, "image0"),
        (lambda a: {**a, "flow01": a["flow01"][:-1]}, "flow01"),
        (lambda a: {**a, "flow10": a["flow10"][..., :1]}, "flow10"),
        (lambda a: {**a, "flow10": np.where(a["flow10"] > 5, np.nan, a["flow10"])}, "flow10"),
        (lambda a: {**a, "flow01": np.full_like(a["flow01"], np.inf)}, "flow01"),
        (lambda a: {**a, "flow01": a["flow01"].astype(np.complex64)}, "flow01"),
        (lambda a: {**a, "alpha": 1.5}, "alpha"),
        (lambda a: {**a, "alpha": -0.1}, "alpha"),
        (lambda a: {**a, "alpha": float("nan")}, "alpha"),
        (lambda a: {**a, "alpha": "0.5"}, "alpha"),
        (lambda a: {**a, "collision": "depth"}, "collision"),
    ],
)
def test_bad_inputs_raise_naming_the_argument(pair, change, name):
    image0, image1, flow01, flow10 = pair
    args = {"image0": image0, "image1": image1, "flow01": flow01, "flow10": flow10}
    args = change({**args, "alpha": 0.5})
    with pytest.raises(MiketalkError, match=name):
        morph(**args)


def test_bad_inputs_of_the_helpers(pair):
    image0, _, flow01, _ = pair
    with pytest.raises(MiketalkError, match="image"):
        forward_warp(image0.astype(np.int16), flow01, 0.5)
    with pytest.raises(MiketalkError, match="flow"):
        forward_warp(image0, flow01[:, :-2], 0.5)
    with pytest.raises(MiketalkError, match="hole"):
        fill_holes_scanline(image0, np.zeros(image0.shape[:2], np.uint8))
    with pytest.raises(MiketalkError, match="hole"):
        fill_holes_scanline(image0, np.zeros((3, 3), bool))
    with pytest.raises(MiketalkError, match="alpha"):
        Morpher(*pair).frame(2)
