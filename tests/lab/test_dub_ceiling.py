"""The face-crop dub's ceiling (the real frames pasted back into themselves) and its tables."""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pandas as pd
import pytest

from miketalk.composite.compositor import Compositor
from miketalk.errors import MiketalkError

SIZE = (96, 96)
MOUTH = (33, 60, 30, 8)


def _frames(n: int = 3, shape=(140, 180)) -> np.ndarray:
    rng = np.random.default_rng(4)
    out = []
    for _ in range(n):
        noise = rng.normal(size=(*shape, 3)).astype(np.float32)
        out.append(np.clip(128 + 60 * cv2.GaussianBlur(noise, (0, 0), 3.0) * 3, 0, 255))
    return np.stack(out).astype(np.uint8)


def _dub(frames: np.ndarray):
    transforms = []
    for k in range(len(frames)):
        t = cv2.getRotationMatrix2D((48.0, 48.0), 4.0 * k, 1.3)  # reference -> frame
        t[:, 2] += (30.0 + 1.5 * k, 12.25)
        transforms.append(t)
    background = SimpleNamespace(transforms=np.stack(transforms), field=None,
                                 index=lambda k, fps: k)  # fmt: skip
    return SimpleNamespace(source=frames, background=background, fps=25.0,
                           boxes=[(0, 0, 1, 1)] * len(frames))  # fmt: skip


def test_the_real_frames_pasted_back_into_themselves_come_back_nearly_as_they_were():
    from miketalk_lab.evaluation.dub_crop_ceiling import real_in_reference, roundtrip_frames

    frames = _frames()
    dub = _dub(frames)
    steady = real_in_reference(dub, SIZE)
    assert steady.shape == (3, *SIZE, 3)
    # the reference's centre shows the frame's pixel its transform puts it at
    t = dub.background.transforms[1]
    x, y = t @ np.array([48.0, 48.0, 1.0])
    assert np.abs(steady[1, 48, 48].astype(int) - frames[1, round(y), round(x)]).max() <= 20
    compositor = Compositor(MOUTH, SIZE, follow=False)  # the jaw's warp may reach beyond
    back = roundtrip_frames(dub, steady, compositor)
    for k in range(3):
        alpha = compositor.place(dub.background.transforms[k], frames.shape[1:3])
        full = alpha.full_alpha(frames.shape[1:3])
        assert np.array_equal(back[k][full == 0], frames[k][full == 0])
        err = (back[k].astype(float) - frames[k].astype(float))[full > 0.5] ** 2
        assert 10 * np.log10(255.0**2 / err.mean()) > 30  # two resamplings of smooth noise


def test_a_crop_compositor_warps_the_jaw_one_of_three_ways_only(tmp_path):
    from miketalk_lab.evaluation.dub_crop_ceiling import FOLLOWS, crop_compositor

    assert FOLLOWS == ("on", "face", "off")
    with pytest.raises(MiketalkError, match="follow must be one of"):
        crop_compositor(tmp_path, SIZE, "sometimes")


def test_the_tables_pair_the_dub_with_its_ceiling_and_the_warps_ways():
    from miketalk_lab.bench.dub_ceiling import tables

    rng = np.random.default_rng(1)
    cols = {}
    for way in ("real_ref", "roundtrip", "render", "on", "face", "off"):
        for m in ("lip_opening_amplitude_speech", "lip_opening_corr_speech", "mouth_lmd",
                  "seam_ratio", "moved_outside_px", "psnr_outside"):  # fmt: skip
            cols[f"{way}_{m}"] = 1.0 + 0.1 * rng.random(4)
    table = pd.DataFrame(cols, index=[f"c{k}" for k in range(4)])
    table["roundtrip_lip_opening_amplitude_speech"] = table["real_ref_lip_opening_amplitude_speech"]
    text = tables(table)
    assert text.startswith("4 clips")
    row = next(line for line in text.splitlines() if line.startswith("| ceiling_kept | on_kept"))
    assert "| 1.000 (0.000) |" in row  # the ceiling: the roundtrip kept all of it
    assert "| on_moved_outside_px | off_moved_outside_px |" in text
