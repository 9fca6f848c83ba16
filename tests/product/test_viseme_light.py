"""The morph's viseme images brought to the face's light (miketalk.draw.trained.light's
lit_visemes, Model.image): an image cut from another day's frame takes the face's light where
the build pasted it, and nothing else moves."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from miketalk import defaults
from miketalk.corpus.viseme_choice import PASTE_FEATHER, composite, paste_weight
from miketalk.draw.trained.light import VISEME_LIGHTS, lit_visemes, pasted, source_frames
from miketalk.draw.trained.mouths import PATCH_EXTENT, MouthFrames, describe, patch_box
from miketalk.errors import MiketalkError
from miketalk.mouth.region import FLOW_EXTENT, REGION_EXTENT
from miketalk.visemes import SILENCE
from miketalk_lab.bench.colour_dub import switches

SIZE = (120, 140)  # (H, W): a face, its mouth 30 px wide, 70 px down
MOUTH = (55, 66, 30, 8)
SKIN, LIPS, DARK, HAIR = (180, 130, 105), (150, 80, 85), (40, 20, 20), (60, 45, 40)
#: Another day's light, in CIELAB: darker, pinker and warmer (``lab + SHIFT``).
SHIFT = np.array([-8.0, 8.0, 6.0], np.float32)


def _face(opening: int, rng: np.random.Generator) -> np.ndarray:
    """A whole face of day 1: hair above, skin, lips and a mouth ``opening`` px high."""
    image = np.empty((*SIZE, 3), np.float32)
    image[:] = SKIN
    image[:25] = HAIR
    cx, cy = MOUTH[0] + MOUTH[2] // 2, MOUTH[1] + MOUTH[3] // 2
    cv2.ellipse(image, (cx, cy), (16, 5 + opening // 2), 0, 0, 360, LIPS, -1)
    if opening:
        cv2.ellipse(image, (cx, cy), (12, opening // 2), 0, 0, 360, DARK, -1)
    image += rng.normal(0, 3, (*SIZE, 1)).astype(np.float32)
    return image


def _another_day(images: np.ndarray) -> np.ndarray:
    lab = cv2.cvtColor(images.reshape(-1, SIZE[1], 3) / 255, cv2.COLOR_RGB2Lab) + SHIFT
    return (cv2.cvtColor(lab, cv2.COLOR_Lab2RGB) * 255).reshape(images.shape)


def _u8(images: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(images), 0, 255).astype(np.uint8)


def _about(extent: tuple[float, float, float]) -> tuple[int, int, int, int]:
    return patch_box(MOUTH, SIZE, extent)


@pytest.fixture(scope="module")
def two_days() -> dict:
    """Day 1 and day 2 filming the same 12 mouths (day 2 :data:`SHIFT`ed), the trained face's
    frames of both (their patches and descriptions, as a build measures them), and viseme
    images laid onto day 1's closed mouth as the build lays them: the silence image from day 1,
    the others from day 2's frames, with what they should become (day 1's same frames)."""
    rng = np.random.default_rng(3)
    openings = np.arange(12)
    day1 = np.stack([_face(int(k), rng) for k in openings])
    day2 = _another_day(day1)
    whole = _u8(np.concatenate([day1, day2]))
    px, py, pw, ph = patch = _about(PATCH_EXTENT)
    region = _about(REGION_EXTENT)
    patches = np.ascontiguousarray(whole[:, py : py + ph, px : px + pw])
    coords, mean, components, variance = describe(patches, patch=patch, region=region, components=4)
    clip = np.repeat([0, 1], len(openings))
    frames = MouthFrames(
        coords=coords, patches=patches, border=np.zeros((len(clip), 3), np.float32), clip=clip,
        clip_frame=np.concatenate([openings, openings]), clip_ids=("day1", "day2"), mean=mean,
        components=components, variance=variance, region=region, patch=patch, fps=25.0,
    )  # fmt: skip
    reference = whole[0]
    flow, feather = _about(FLOW_EXTENT), PASTE_FEATHER * region[2]
    cut = {"a": 4, "b": 8, "c": 11}  # viseme -> its day-2 frame (of ``whole``: 12 later)
    images = {SILENCE: composite(whole[1], reference, flow, feather=feather)}
    images |= {
        v: composite(whole[12 + k], reference, flow, feather=feather) for v, k in cut.items()
    }
    truth = {v: composite(whole[k], reference, flow, feather=feather) for v, k in cut.items()}
    weight = paste_weight(SIZE, flow, feather=feather)
    return {"frames": frames, "images": images, "truth": truth, "cut": cut, "weight": weight}


def test_another_days_viseme_images_take_the_faces_light_where_they_were_pasted(
    two_days,
) -> None:
    frames, images, truth = two_days["frames"], two_days["images"], two_days["truth"]
    weight = two_days["weight"]
    # each image's own frame is found among the trained face's (its clip: day 2)
    found = source_frames(images, frames)
    assert found == {SILENCE: 1, **{v: 12 + k for v, k in two_days["cut"].items()}}
    # the build's paste is known from the trained face's mouth region (to its rounding: a
    # pixel at this small mouth's edge, none on the canonical crop's)
    error = np.abs(pasted(frames, SIZE) - weight)
    assert error.max() < 0.3 and error.mean() < 0.02
    lit = lit_visemes(images, frames, "session")
    inside, outside = weight > 0.99, weight == 0
    for v in two_days["cut"]:
        raw = np.abs(images[v].astype(np.float32) - truth[v])[inside].mean()
        now = np.abs(lit[v].astype(np.float32) - truth[v])[inside].mean()
        assert raw > 15  # another day's light: 21 levels off
        assert now < 3  # the face's: 1.5 to 1.8
        assert np.array_equal(lit[v][outside], images[v][outside])  # the rest of the face
    assert lit[SILENCE] is images[SILENCE]  # the face itself
    built = lit_visemes(images, frames, "built")
    assert all(built[v] is images[v] for v in images)


def test_an_image_that_is_no_training_frame_stays_as_built(two_days) -> None:
    frames, images = two_days["frames"], two_days["images"]
    noisy = images["a"].astype(np.int16) + np.random.default_rng(0).integers(-9, 10, (*SIZE, 3))
    other = {**images, "a": np.clip(noisy, 0, 255).astype(np.uint8)}
    assert source_frames(other, frames)["a"] is None
    lit = lit_visemes(other, frames)
    assert lit["a"] is other["a"] and not np.array_equal(lit["b"], other["b"])
    with pytest.raises(MiketalkError, match="the viseme images' light must be built or session"):
        lit_visemes(images, frames, "sun")


def test_the_default_and_the_bench_switch_name_a_viseme_light() -> None:
    assert VISEME_LIGHTS == ("built", "session") and defaults.VISEME_LIGHT == "session"
    assert switches("lips+visemes=built") == {"BLEND_COLOUR": "lips", "VISEME_LIGHT": "built"}
    with pytest.raises(ValueError, match="'visemes=sun' is none of"):
        switches("visemes=sun")


def test_a_model_from_clips_draws_its_viseme_images_in_its_faces_light(s1_built) -> None:
    """s1's model from four clips: every viseme image's own frame is found; the paper's
    morph draws the lit images (the default), ``"built"`` the files; the learned
    coarticulation's images (``image``, ``frame``) stay the files; s1's one studio light
    moves them little."""
    from miketalk.media.images import read_image
    from miketalk.model.face import Model

    with Model(s1_built, viseme_light="built") as built, Model(s1_built) as model:
        files = {v: read_image(s1_built / built.manifest["images"][v]) for v in built.visemes}
        assert all(np.array_equal(built.lit_image(v), files[v]) for v in built.visemes)
        frames = model.trained_face.frames
        assert None not in source_frames(files, frames).values()
        want = lit_visemes(files, frames)
        drawn = {v: model.lit_image(v) for v in model.visemes}
        assert all(np.array_equal(drawn[v], want[v]) for v in model.visemes)
        assert all(np.array_equal(model.image(v), files[v]) for v in model.visemes)
        assert np.array_equal(drawn[SILENCE], files[SILENCE])
        moved = [np.abs(drawn[v].astype(np.int16) - files[v]).mean() for v in model.visemes]
        assert 0 < max(moved) < 3  # one studio's light
        # the paper's drawing morphs the lit images; a frame asked for plainly, the files
        v = model.visemes[int(np.argmax(moved))]
        assert np.array_equal(model.frame(v, SILENCE, 0.0, lit=True), want[v])
        assert np.array_equal(model.frame(v, SILENCE, 0.0), files[v])
        assert np.array_equal(built.frame(v, SILENCE, 0.0, lit=True), files[v])
        lit, plain = model.frame(v, SILENCE, 0.5, lit=True), model.frame(v, SILENCE, 0.5)
        assert not np.array_equal(lit, plain)
        assert np.array_equal(plain, built.frame(v, SILENCE, 0.5, lit=True))
    with pytest.raises(MiketalkError, match="the viseme images' light must be"):
        Model(s1_built, viseme_light="sun")
