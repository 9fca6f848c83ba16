"""The trained face's patches brought to the face's light, clip by clip
(miketalk.draw.trained.light): another day's light on the same mouths is undone."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from miketalk import defaults
from miketalk.draw.trained.light import PATCH_LIGHTS, lower_face, patch_light
from miketalk.draw.trained.mouths import MouthFrames, describe, feather_mask
from miketalk.draw.trained.selection import PatchCompositor
from miketalk.errors import MiketalkError
from miketalk_lab.bench.colour_dub import switches

H, W = 64, 92  # the patch: a mouth 40 px wide (W / 2.3), its centre 30 px down
REGION = (26, 20, 40, 20)
SKIN, LIPS, DARK = (180, 130, 105), (150, 80, 85), (40, 20, 20)

#: Another day's light, in CIELAB: darker, pinker and warmer (``lab + SHIFT``), and its collar
#: and suit across the patch's bottom (in the border band, outside the lower face).
SHIFT = np.array([-8.0, 8.0, 6.0], np.float32)
SUIT = (35, 35, 45)

#: A day's camera that also spreads the colours: ``lab * SCALE + SHIFT`` (more saturated).
SCALE = np.array([0.85, 1.3, 1.25], np.float32)


def _mouth(opening: int, rng: np.random.Generator) -> np.ndarray:
    """A lower face: skin, lips, a dark mouth ``opening`` px high, a little texture."""
    image = np.empty((H, W, 3), np.float32)
    image[:] = SKIN
    cv2.ellipse(image, (46, 30), (20, 6 + opening // 2), 0, 0, 360, LIPS, -1)
    if opening:
        cv2.ellipse(image, (46, 30), (15, opening // 2), 0, 0, 360, DARK, -1)
    image += rng.normal(0, 3, (H, W, 1)).astype(np.float32)
    return image


def _frames(patches: np.ndarray, clip: np.ndarray) -> MouthFrames:
    coords, mean, components, variance = describe(patches, patch=(0, 0, W, H), region=REGION,
                                                  components=3)  # fmt: skip
    clip_frame = np.concatenate([np.arange((clip == c).sum()) for c in np.unique(clip)])
    mask = feather_mask(H, W)
    band = (mask > 0.02) & (mask < 0.98)  # as measure_frames takes it
    return MouthFrames(
        coords=coords, patches=patches, border=patches[:, band].astype(np.float32).mean(axis=1),
        clip=clip, clip_frame=clip_frame, clip_ids=("day1", "day2"), mean=mean,
        components=components, variance=variance, region=REGION, patch=(0, 0, W, H), fps=25.0,
    )  # fmt: skip


def _two_days(scale: np.ndarray, shift: np.ndarray, suit: bool) -> tuple:
    """The same 30 mouths filmed on two days (the second ``lab * scale + shift``, with the
    :data:`SUIT` at its bottom when ``suit``), the face (day 1's closed mouth) and day 1's
    patches (what day 2's should become)."""
    rng = np.random.default_rng(4)
    openings = np.tile(np.arange(0, 15), 2)
    day1 = np.clip(np.stack([_mouth(int(k), rng) for k in openings]), 0, 255)
    lab = cv2.cvtColor(day1.reshape(-1, W, 3) / 255, cv2.COLOR_RGB2Lab) * scale + shift
    day2 = (cv2.cvtColor(lab, cv2.COLOR_Lab2RGB) * 255).reshape(day1.shape)
    if suit:
        day2[:, -11:] = SUIT
    patches = np.clip(np.rint(np.concatenate([day1, day2])), 0, 255).astype(np.uint8)
    frames = _frames(patches, np.repeat([0, 1], len(openings)))
    face = np.clip(np.rint(_mouth(0, np.random.default_rng(9))), 0, 255).astype(np.uint8)
    return frames, face, patches[: len(openings)]


@pytest.fixture(scope="module")
def two_days() -> tuple[MouthFrames, np.ndarray, np.ndarray]:
    """:func:`_two_days` of another day's light (:data:`SHIFT`) and suit."""
    return _two_days(np.ones(3, np.float32), SHIFT, suit=True)


def _error(light: str, two_days, where: np.ndarray) -> float:
    frames, face, truth = two_days
    match = patch_light(frames, face, light)
    second = np.flatnonzero(frames.clip == 1)
    lit = np.stack([match.apply(frames.patches[s], 1) for s in second])
    return float(np.abs(lit - truth.astype(np.float32))[:, where].mean())


def _lips() -> np.ndarray:
    lips = np.zeros((H, W), np.uint8)
    cv2.ellipse(lips, (46, 30), (20, 12), 0, 0, 360, 1, -1)
    return lips.astype(bool)


def test_session_light_undoes_another_days_light_where_a_border_offset_does_not(
    two_days,
) -> None:
    frames, face, truth = two_days
    lips = _lips()
    assert lower_face(frames)[lips].all() and not lower_face(frames)[-11:].any()
    raw = float(np.abs(frames.patches[30:].astype(np.float32) - truth)[:, lips].mean())
    border, session = _error("border", two_days, lips), _error("session", two_days, lips)
    assert raw > 10  # the second day's lips are another colour (20 levels)
    assert session < 3  # 2.1
    assert border > 10  # 15.3: the suit in the border band darkened the offset
    # day 1's own patches (the face's light) are nearly unchanged
    match = patch_light(frames, face, "session")
    first = np.stack([match.apply(p, 0) for p in frames.patches[:30]])
    assert np.abs(first - truth)[:, lips].mean() < 1  # 0.2


def test_a_spread_limit_lets_the_transfer_undo_a_camera_that_spreads_the_colours(
    monkeypatch,
) -> None:
    """The default holds each channel's spread (:data:`SPREAD_LIMIT` 1); a limit above one
    scales it too, and undoes a day whose colours are more saturated."""
    from miketalk.draw.trained import light

    days = _two_days(SCALE, np.array([4.0, 3.0, -4.0], np.float32), suit=False)
    lips = _lips()
    assert light.SPREAD_LIMIT == 1.0
    held = _error("session", days, lips)
    monkeypatch.setattr(light, "SPREAD_LIMIT", 1.5)
    scaled = _error("session", days, lips)
    assert scaled < 2 < 6 < held  # 0.9 against 8.4


def test_border_light_is_the_offset_before_and_a_light_is_named(two_days) -> None:
    frames, face, _ = two_days
    compositor = PatchCompositor(frames, face, light="border")
    for s in (0, 40):
        offset = compositor.light.shift[frames.clip[s]]
        want = frames.patches[s].astype(np.float32) + offset
        assert np.array_equal(compositor.lit(s), want)
    default = PatchCompositor(frames, face).light
    want = patch_light(frames, face, defaults.PATCH_LIGHT)
    assert type(default) is type(want)
    assert np.array_equal(default.apply(frames.patches[40], 1), want.apply(frames.patches[40], 1))
    with pytest.raises(MiketalkError, match="the patches' light must be border or session"):
        PatchCompositor(frames, face, light="sun")
    assert PATCH_LIGHTS == ("border", "session")


def test_the_bench_switch_names_a_colour_match_and_a_patch_light() -> None:
    assert switches("lips+patches=session") == {"BLEND_COLOUR": "lips", "PATCH_LIGHT": "session"}
    assert switches("patches=border") == {"PATCH_LIGHT": "border"}
    with pytest.raises(ValueError, match="'patches=sun' is none of"):
        switches("gain+patches=sun")
