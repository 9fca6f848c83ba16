"""Compositing a mouth into video frames: synthetic ground truth (known affine and field)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from miketalk.composite.compositor import Compositor, blend_mask, colour_offset
from miketalk.errors import MiketalkError
from miketalk.stabilize import Stabilizer
from miketalk_lab.evaluation.measures import sharpness

SIZE = (160, 200)
MOUTH = (80, 100, 40, 10)  # x, y, w, h: centre (100, 105), 40 px wide


def _texture(seed: int = 3, shape: tuple[int, int] = SIZE) -> np.ndarray:
    """Smooth colour noise: detail at several scales, like skin and lips under a camera."""
    rng = np.random.default_rng(seed)
    out = np.zeros((*shape, 3), np.float32)
    for sigma, gain in ((1.5, 25.0), (4.0, 60.0), (12.0, 120.0)):
        noise = rng.normal(size=(*shape, 3)).astype(np.float32)
        out += gain * cv2.GaussianBlur(noise, (0, 0), sigma) * sigma
    return np.clip(128 + out, 0, 255).astype(np.uint8)


def _affine(angle: float = 3.0, scale: float = 1.04, shift=(5.3, -3.7)) -> np.ndarray:
    t = cv2.getRotationMatrix2D((100.0, 80.0), angle, scale)
    t[:, 2] += shift
    return t


def _field() -> np.ndarray:
    """A smooth conform field of up to 2 px, as :meth:`Stabilizer.conform` makes."""
    yy, xx = np.mgrid[0 : SIZE[0], 0 : SIZE[1]].astype(np.float32)
    dx = 1.5 * np.sin(xx / 40.0) * np.cos(yy / 50.0)
    dy = 1.2 * np.cos(xx / 60.0 + 0.3) * np.sin(yy / 35.0)
    return np.stack([dx, dy], axis=-1).astype(np.float32)


def _stabilizer() -> Stabilizer:
    return Stabilizer(_texture(), np.ones(SIZE, bool))


def _psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    err = (a.astype(np.float64) - b.astype(np.float64))[mask] ** 2
    return float(10 * np.log10(255.0**2 / err.mean()))


@pytest.mark.parametrize("with_field", [False, True])
def test_a_frames_own_stabilized_mouth_composites_back_to_the_frame(with_field):
    frame = _texture(seed=11)
    transform = _affine()
    field = _field() if with_field else None
    stabilized = _stabilizer().apply(frame[None], transform[None], field=field)[0]
    compositor = Compositor(MOUTH, SIZE, colour_match=False)
    out = compositor(frame, stabilized, transform, field=field)
    placed = compositor.place(transform, SIZE, field=field).full_alpha(SIZE)
    inside = placed > 0.01
    assert inside.sum() > 2000
    # resampling twice costs a little (55.3 dB through bicubic, 51.7 through bilinear), and
    # something: the frame left as it was, no mouth composited, measures 86 dB or more;
    # leaving the field's inverse out misplaces the mouth by up to 2 px (40.0 dB)
    assert 45.0 < _psnr(out, frame, inside) < 65.0
    assert np.array_equal(out[~inside], frame[~inside])


def test_the_mouth_lands_where_the_transform_puts_it():
    frame = _texture(seed=11)
    transform = _affine(angle=-4.0, shift=(9.0, 6.0))
    render = np.zeros((*SIZE, 3), np.uint8)
    render[100:110, 95:105] = 255  # a white square about the mouth's centre (100, 105)
    compositor = Compositor(MOUTH, SIZE, colour_match=False)
    out = compositor(np.zeros_like(frame), render, transform)
    ys, xs = np.nonzero(out[..., 0] > 128)
    found = np.array([xs.mean(), ys.mean()])
    expected = transform @ np.array([99.5, 104.5, 1.0])
    assert np.abs(found - expected).max() < 0.3


def test_blend_mask_covers_lips_and_chin_and_fades_out():
    alpha = blend_mask(MOUTH, SIZE)
    cx, cy, w = 100, 105, 40
    assert alpha[cy, cx] == pytest.approx(1.0, abs=1e-3)  # the lips
    assert alpha[round(cy + 0.6 * w), cx] > 0.95  # the chin
    assert alpha[round(cy - 1.0 * w), cx] == 0  # the nose and above: the frame's own
    assert alpha[cy, round(cx + 1.6 * w)] == 0  # the cheek beyond the jaw line
    assert alpha.max() <= 1.0 and alpha.min() >= 0.0


def test_colour_match_follows_the_frames_light():
    frame = _texture(seed=11)
    transform = _affine()
    stabilized = _stabilizer().apply(frame[None], transform[None])[0]
    darker = np.clip(stabilized.astype(np.int16) - 30, 0, 255).astype(np.uint8)
    plain = Compositor(MOUTH, SIZE, colour_match=False)(frame, darker, transform)
    matched = Compositor(MOUTH, SIZE, colour="offset")(frame, darker, transform)
    inside = Compositor(MOUTH, SIZE).place(transform, SIZE).full_alpha(SIZE) > 0.01
    assert _psnr(matched, frame, inside) > _psnr(plain, frame, inside) + 10
    assert _psnr(matched, frame, inside) > 30.0
    # the render is what shows there: unmatched, its darker light (17.5 grey levels under the
    # frame's); matched, the frame's (within 0.01)
    level = frame[inside].mean()
    assert level - plain[inside].mean() > 10 and abs(matched[inside].mean() - level) < 1


@pytest.mark.parametrize("whole_background", [False, True])
def test_a_gain_carries_another_lights_colour_onto_the_lips(whole_background):
    """A render under another light (each channel scaled: redder, dimmer) is brought back to
    the frame's by the gain, the lips' contrast with the skin included; an offset learned on
    the same skin leaves the darker and lighter parts off (the lips grey)."""
    frame = _texture(seed=11)
    transform = _affine()
    stabilized = _stabilizer().apply(frame[None], transform[None])[0]
    light = np.float32([0.6, 0.75, 0.9])  # another day's light
    other = np.clip(stabilized * light + 0.5, 0, 255).astype(np.uint8)
    inside = Compositor(MOUTH, SIZE).place(transform, SIZE).full_alpha(SIZE) > 0.5
    scores = {}
    for how in ("offset", "gain"):
        compositor = Compositor(MOUTH, SIZE, colour=how)
        match = compositor.colour_field(other, stabilized) if whole_background else None
        out = compositor(frame, other, transform, offset=match)
        scores[how] = _psnr(out, frame, inside)
    assert scores["gain"] > 35.0
    assert scores["gain"] > scores["offset"] + 5
    with pytest.raises(MiketalkError, match="colour match must be offset or gain"):
        Compositor(MOUTH, SIZE, colour="histogram")


def test_lips_take_the_backgrounds_own_lips_colour():
    """A render whose lips alone are greyer than the person's under this light (the skin the
    same): ``lips`` learns over the whole blend, from the background's median, and gives the
    lips back their colour; ``offset`` and ``gain``, learned on the skin at the edge, cannot."""
    frame = _texture(seed=11)
    transform = _affine()
    stabilized = _stabilizer().apply(frame[None], transform[None])[0]
    x, y, w, h = MOUTH
    lips = np.zeros(SIZE, np.float32)
    cv2.ellipse(lips, (x + w // 2, y + h // 2), (w // 2, h), 0, 0, 360, 1.0, -1)
    lips = cv2.GaussianBlur(lips, (0, 0), 2.0)[..., None]
    grey = stabilized.astype(np.float32) + lips * np.float32([-25, 10, 10])  # less red
    grey = np.clip(grey + 0.5, 0, 255).astype(np.uint8)
    placed = Compositor(MOUTH, SIZE).place(transform, SIZE)
    on_lips = np.zeros(SIZE, bool)
    x0, y0, x1, y1 = placed.box
    on_lips[y0:y1, x0:x1] = cv2.remap(lips[..., 0], placed.map_x, placed.map_y,
                                      cv2.INTER_LINEAR) > 0.5  # fmt: skip
    scores = {}
    for how in ("offset", "gain", "lips"):
        compositor = Compositor(MOUTH, SIZE, colour=how)
        out = compositor(frame, grey, transform, offset=compositor.colour_field(grey, stabilized))
        scores[how] = _psnr(out, frame, on_lips)
    assert scores["lips"] > scores["offset"] + 6 and scores["lips"] > scores["gain"] + 6
    assert scores["lips"] > 33.0  # 35.9 measured; offset and gain 24.7


def test_colour_offset_is_the_band_difference_for_a_constant_shift():
    render = np.full((30, 40, 3), 100, np.float32)
    frame = render + np.float32([10, -5, 3])
    band = np.zeros((30, 40), np.float32)
    band[:3] = 1
    offset = colour_offset(render, frame, band, sigma=8.0)
    assert np.allclose(offset, [10, -5, 3], atol=1e-3)


def test_a_render_of_another_size_or_a_bad_transform_is_refused():
    compositor = Compositor(MOUTH, SIZE)
    frame = _texture()
    with pytest.raises(MiketalkError, match="render"):
        compositor(frame, frame[:100], _affine())
    with pytest.raises(MiketalkError, match="transform"):
        compositor(frame, frame, np.full((2, 3), np.nan))


def test_a_region_outside_the_frame_leaves_it_as_it_was():
    frame = _texture()
    far = _affine(shift=(1000.0, 0.0))
    assert np.array_equal(Compositor(MOUTH, SIZE)(frame, frame, far), frame)


def test_poisson_blend_gives_back_the_frame_and_keeps_the_frames_light():
    frame = _texture(seed=11)
    transform = _affine()
    stabilized = _stabilizer().apply(frame[None], transform[None])[0]
    compositor = Compositor(MOUTH, SIZE, blend="poisson", colour_match=False)
    inside = compositor.place(transform, SIZE).full_alpha(SIZE) > 0.5
    # 49.4 dB; under 60, the render is cloned in (the frame left as it was: 67.9 dB or more)
    assert 44.0 < _psnr(compositor(frame, stabilized, transform), frame, inside) < 60.0
    # a render 40 grey levels darker: the gradient-domain blend takes the frame's level
    darker = np.clip(stabilized.astype(np.int16) - 40, 0, 255).astype(np.uint8)
    assert 44.0 < _psnr(compositor(frame, darker, transform), frame, inside) < 60.0  # 47.8
    with pytest.raises(MiketalkError, match="blend"):
        Compositor(MOUTH, SIZE, blend="median")


def test_follow_render_moves_the_frames_jaw_to_the_renders_beside_the_mask():
    from miketalk.composite.follow import follow_render

    h, w = 120, 200
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    texture = _texture(seed=5, shape=(h, w)).astype(np.float32)

    here = texture * (1.0 - 0.6 / (1.0 + np.exp(-(yy - 60.0))))[..., None]  # a jaw line at 60
    drop = 6.0 * np.clip((yy - 40.0) / 15.0, 0.0, 1.0)  # the render's jaw 6 px lower
    render = cv2.remap(here, xx, yy - drop, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    alpha = np.zeros((h, w), np.float32)
    alpha[30:90, 60:140] = 1.0  # the mask over the middle
    box = (80, 30, 40, 10)  # its mouth: centre row 35, 40 px wide
    out = follow_render(here, render, alpha, yy, box)

    def edge(image: np.ndarray, col: int) -> float:  # the row where the jaw line falls
        profile = image[:, col].mean(axis=1)
        return float(np.argmin(np.diff(profile[40:85])) + 40.5)

    assert abs(edge(here, 150) - 60) <= 1 and abs(edge(render, 150) - 66) <= 1
    # at the mask's edge the frame's jaw continues the render's (65.5 measured), half a
    # mouth width beyond it its own (60.5); without the warp it would stay at 60
    assert abs(edge(out, 140) - 66) <= 1
    assert 61 <= edge(out, 145) <= 65
    assert abs(edge(out, 165) - 60) <= 1 and abs(edge(out, 195) - 60) <= 1
    # above the mouth nothing moves
    assert np.abs(out[:20] - here[:20]).max() < 1.0


def test_skin_weight_keeps_face_and_lips_and_drops_backdrop_and_collar():
    from miketalk.composite.follow import skin_weight

    image = np.zeros((60, 90, 3), np.uint8)
    image[:] = (40, 150, 200)  # blue backdrop
    image[10:40, 20:70] = (200, 150, 120)  # skin
    image[25:30, 35:55] = (190, 80, 90)  # lips
    image[45:, :] = (70, 80, 100)  # a denim collar
    face = np.zeros((60, 90), bool)
    face[12:38, 22:68] = True
    keep = skin_weight(image, face)
    assert keep[20, 45] > 0.99 and keep[27, 45] > 0.99  # skin, lips
    assert keep[5, 5] < 0.01 and keep[55, 45] < 0.01  # backdrop, collar


def test_cubic_sampling_keeps_the_detail_bilinear_sampling_averages_away():
    frame = _texture(seed=5)
    transform = _affine(angle=1.0, scale=1.0, shift=(3.5, -2.5))  # half-pixel offsets
    stabilized = _stabilizer().apply(frame[None], transform[None])[0]
    inside = Compositor(MOUTH, SIZE).place(transform, SIZE).full_alpha(SIZE) > 0.99
    kept, fidelity = {}, {}
    for how in ("linear", "cubic"):
        out = Compositor(MOUTH, SIZE, colour_match=False, interpolation=how)(
            frame, stabilized, transform
        )
        kept[how] = sharpness(out, inside) / sharpness(frame, inside)
        fidelity[how] = _psnr(out, frame, inside)
    # the frame's own mouth, resampled twice, comes back softer; less so through cubic
    assert kept["linear"] < kept["cubic"] < 1.0  # 0.81, 0.95 (PSNR 50.0, 53.1 dB)
    assert kept["cubic"] - kept["linear"] > 0.05
    assert fidelity["cubic"] > fidelity["linear"]
    with pytest.raises(MiketalkError, match="interpolation"):
        Compositor(MOUTH, SIZE, interpolation="nearest")


def test_the_round_trip_calibration_measures_what_compositing_costs_a_perfect_mouth():
    from types import SimpleNamespace

    from miketalk_lab.evaluation.dubbing import DubbedClip, roundtrip_measures

    frames = np.stack([_texture(seed=s) for s in (1, 2, 3)])
    transforms = np.stack([_affine(shift=(dx, 1.5)) for dx in (0.5, 2.25, -1.75)])
    background = SimpleNamespace(transforms=transforms, field=None)
    clip = DubbedClip(frames, frames, frames, np.zeros(frames.shape[:3]), background)
    stabilizer = _stabilizer()
    steady = stabilizer.apply(frames, transforms)
    scores = {}
    for how in ("linear", "cubic"):
        compositor = Compositor(MOUTH, SIZE, interpolation=how)
        scores[how] = roundtrip_measures(
            clip, steady, stabilizer=stabilizer, compositor=compositor, mouth_box=MOUTH
        )
    for s in scores.values():
        assert 0.6 < s["roundtrip_sharpness_ratio"] < 0.99  # 0.85 linear, 0.95 cubic
        assert 45.0 < s["roundtrip_psnr_mouth"] < 60.0  # 50.1, 54.6
    linear, cubic = scores["linear"], scores["cubic"]
    assert cubic["roundtrip_sharpness_ratio"] > linear["roundtrip_sharpness_ratio"] + 0.05
    assert cubic["roundtrip_psnr_mouth"] > linear["roundtrip_psnr_mouth"]


def test_each_shot_of_a_background_gets_the_mouth_in_its_own_light():
    """A video cut from one light to another (one weekly address to the next): matched once
    to the whole video's median light, the mouth was a dark blob in the brighter shot; now
    each shot's own median."""
    from miketalk.composite.background import Background, composited

    dim = _texture(seed=11)
    bright = np.clip(dim.astype(np.int16) + 50, 0, 255).astype(np.uint8)
    frames = np.stack([dim, dim, bright, bright])
    identity = np.repeat(np.eye(2, 3)[None], 4, axis=0)
    middle = np.clip(dim.astype(np.int16) + 25, 0, 255).astype(np.uint8)
    compositor = Compositor(MOUTH, SIZE)
    inside = compositor.place(identity[0], SIZE).full_alpha(SIZE) > 0.01

    def dubbed(steady_shots):
        background = Background(frames, identity, None, 25.0, steady=middle,
                                shot=np.array([0, 0, 1, 1]), steady_shots=steady_shots)  # fmt: skip
        return list(composited([dim] * 4, background, compositor, fps=25.0, rest=dim))

    once = dubbed(None)
    each = dubbed({0: dim, 1: bright})
    for k in range(4):
        error = [np.abs(out[k].astype(int) - frames[k])[inside].mean() for out in (each, once)]
        assert error[0] < 1.0 and error[1] > 10.0  # once: up to 25 levels off in both shots


def test_the_jaws_warp_held_inside_a_region_leaves_the_frame_beyond_it_as_it_was():
    """``follow_within``: a face crop's jaw warp moves no pixel outside its keep (the room
    beside the jaw stays straight); None is the warp as before, to the byte."""
    frame = _texture(seed=7)
    yy = np.mgrid[0 : SIZE[0], 0 : SIZE[1]][0].astype(np.float32)
    xx = np.mgrid[0 : SIZE[0], 0 : SIZE[1]][1].astype(np.float32)
    drop = 5.0 * np.clip((yy - 100.0) / 15.0, 0.0, 1.0)  # the render's jaw 5 px lower
    render = cv2.remap(frame, xx, yy - drop, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    t = _affine()
    before = Compositor(MOUTH, SIZE)(frame, render, t)
    assert np.array_equal(Compositor(MOUTH, SIZE, follow_within=None)(frame, render, t), before)
    inside = Compositor(MOUTH, SIZE)
    held = Compositor(MOUTH, SIZE, follow_within=inside.alpha)(frame, render, t)
    outside = inside.place(t, SIZE).full_alpha(SIZE) == 0
    moved = np.abs(before.astype(int) - frame.astype(int)).max(axis=2) > 8
    assert (moved & outside).sum() > 50  # the warp as before bends what is beyond the mask
    assert np.array_equal(held[outside], frame[outside])
    off = Compositor(MOUTH, SIZE, follow=False)(frame, render, t)
    assert np.array_equal(off[outside], frame[outside])


def test_follow_render_within_zero_moves_nothing():
    from miketalk.composite.follow import follow_render

    h, w = 60, 80
    yy = np.mgrid[0:h, 0:w][0].astype(np.float32)
    here = _texture(seed=2, shape=(h, w)).astype(np.float32)
    render = np.roll(here, 3, axis=0)
    alpha = np.zeros((h, w), np.float32)
    alpha[10:50, 20:60] = 1.0
    out = follow_render(
        here, render, alpha, yy, (30, 10, 20, 5), within=np.zeros((h, w), np.float32)
    )
    assert np.abs(out - here).max() < 1e-3


@pytest.mark.parametrize("crop", [True, False])
def test_a_crop_models_compositor_leaves_the_jaw_unwarped_a_full_frames_warps_it(
    tmp_path, monkeypatch, crop
):
    """``BLEND_FOLLOW_CROP``: a face-crop model's compositor warps the jaw as it says (``off``
    by default; ``face`` holds it in the keep), a full-frame model's as before; given settings
    win."""
    import json

    from miketalk import defaults
    from miketalk.composite.for_model import model_compositor
    from miketalk.media.images import write_png
    from miketalk.model.background import KeptBackground
    from miketalk.track.crop import FaceCropSettings, crop_doc

    where = tmp_path / "background"
    where.mkdir()
    size = FaceCropSettings().size if crop else 96
    doc = {"mouth_box": [size // 2 - 20, int(size * 0.7), 40, 12]}
    if crop:
        doc["crop"] = crop_doc(FaceCropSettings())
    (where / "background.json").write_text(json.dumps(doc), "utf-8")
    write_png(where / "reference.png", np.full((size, size, 3), (200, 140, 120), np.uint8))
    write_png(where / "face_mask.png", np.full((size, size, 3), 255, np.uint8))
    model = KeptBackground(tmp_path)  # what a Model answers of its background
    c = model_compositor(model, (size, size))
    assert c.follow is not crop and c.follow_within is None
    assert model_compositor(model, (size, size), follow=True).follow
    monkeypatch.setattr(defaults, "BLEND_FOLLOW_CROP", "face")
    c = model_compositor(model, (size, size))
    assert c.follow and (c.follow_within is not None) is crop


@pytest.mark.parametrize("blend", ["feather", "poisson"])
def test_frames_in_the_encoders_colours_are_the_composite_converted_whole(blend):
    """Converting only the mouth's box (grown to even corners) into a copy of the background's
    own I420 frame gives what converting the whole composited RGB frame gives, byte for byte,
    on frames the mouth lands in and on frames played without a mouth."""
    from miketalk.composite.background import Background, composited
    from miketalk.media.yuv import I420Frame, to_i420

    frames = np.stack([_texture(seed=s) for s in (11, 12, 13)])
    transforms = np.stack([_affine(), _affine(angle=-2.0, shift=(2.7, 1.3)), _affine()])
    renders = [_texture(seed=s) for s in (21, 22, 23, 24)]
    shown = np.array([True, True, False])
    compositor = Compositor(MOUTH, SIZE, blend=blend)
    plain = Background(frames, transforms, _field(), 25.0, shown=shown)
    coded = Background(frames, transforms, _field(), 25.0, shown=shown,
                       i420=np.stack([to_i420(f) for f in frames]))  # fmt: skip
    rgb = list(composited(renders, plain, compositor, fps=25.0))
    yuv = list(composited(renders, coded, compositor, fps=25.0, i420=True))
    assert all(isinstance(f, I420Frame) for f in yuv)
    changed = [not np.array_equal(r, frames[plain.index(k, 25.0)]) for k, r in enumerate(rgb)]
    assert changed == [True, True, False, True]  # frame 2 plays without a mouth
    for r, y in zip(rgb, yuv, strict=True):
        assert np.array_equal(y.planes, to_i420(r))
    again = list(composited(renders, coded, compositor, fps=25.0))  # not asked: RGB
    assert all(np.array_equal(a, r) for a, r in zip(again, rgb, strict=True))


def test_a_box_pasted_into_i420_planes_is_the_whole_frame_converted():
    from miketalk.media.yuv import even_box, paste_rgb, to_i420

    rng = np.random.default_rng(5)
    for h, w in ((10, 14), (12, 16), (288, 360)):
        a, b = (rng.integers(0, 256, (h, w, 3), np.uint8) for _ in range(2))
        box = even_box((3, 1, w - 3, h - 1), (h, w))
        assert all(v % 2 == 0 for v in box) and box != (0, 0, w, h)
        x0, y0, x1, y1 = box
        whole = a.copy()
        whole[y0:y1, x0:x1] = b[y0:y1, x0:x1]
        planes = to_i420(a)
        paste_rgb(planes, box, b[y0:y1, x0:x1])
        assert np.array_equal(planes, to_i420(whole))
    with pytest.raises(MiketalkError, match="even"):
        paste_rgb(to_i420(a), (1, 0, 4, 4), b[0:4, 1:4])


@pytest.mark.parametrize("follow", [True, False])
def test_renders_that_differ_only_outside_the_region_composite_the_same(follow, monkeypatch):
    """A drawing may draw only the region a background's compositing reads
    (MouthCompositing.region: every frame's placement and the sampling's reach): renders
    that differ only outside it give the same frames, through the jaw's warp too; a change
    inside it shows."""
    from types import SimpleNamespace

    from miketalk import defaults
    from miketalk.composite import for_model as background_files
    from miketalk.composite.background import Background

    monkeypatch.setattr(defaults, "BLEND_FOLLOW", follow)
    monkeypatch.setattr(background_files, "model_compositor",
                        lambda model, size: Compositor(MOUTH, SIZE, follow=follow))  # fmt: skip
    frames = np.stack([_texture(seed=s) for s in (11, 12, 13)])
    transforms = np.stack([_affine(), _affine(angle=-6.0, scale=0.95, shift=(2.7, 1.3)),
                           _affine(angle=8.0, shift=(-4.0, 3.0))])  # fmt: skip
    rest = _texture(seed=30)
    model = SimpleNamespace(size=SIZE, visemes=("x",), image=lambda v: rest)
    background = Background(frames, transforms, _field(), 25.0)
    compositing = background_files.MouthCompositing(model, background)
    x0, y0, x1, y1 = compositing.region
    assert 0 < (x1 - x0) * (y1 - y0) < 0.6 * SIZE[0] * SIZE[1]
    renders = [_texture(seed=s) for s in (21, 22, 23)]
    elsewhere = []
    for r in renders:
        other = _texture(seed=99)
        other[y0:y1, x0:x1] = r[y0:y1, x0:x1]
        elsewhere.append(other)
    same = list(compositing.frames(renders, fps=25.0))
    assert all(np.array_equal(a, b) for a, b in
               zip(same, compositing.frames(elsewhere, fps=25.0), strict=True))  # fmt: skip
    inside = [r.copy() for r in renders]
    inside[1][(y0 + y1) // 2, (x0 + x1) // 2] ^= 0xFF
    changed = list(compositing.frames(inside, fps=25.0))
    assert not np.array_equal(changed[1], same[1])


@pytest.mark.parametrize("count", [1, 2, 7, 100])
def test_the_median_of_frames_is_numpys_cast_to_bytes(count):
    """:func:`~miketalk.composite.registration.median_frames` (a radix sort) gives the bytes
    of ``np.median(frames, axis=0).astype(np.uint8)``, an even count's two middles too."""
    from miketalk.composite.registration import median_frames

    frames = np.random.default_rng(count).integers(0, 256, (count, 9, 11, 3), np.uint8)
    frames[:, 0, 0] = np.array([255 if i % 2 else 0 for i in range(count)])[:, None]  # far apart
    got = median_frames(frames)
    assert got.dtype == np.uint8 and got.shape == (9, 11, 3)
    assert np.array_equal(got, np.median(frames, axis=0).astype(np.uint8))
