"""Image and sync measures against reference implementations and known answers."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage.metrics import structural_similarity

from miketalk.errors import MiketalkError
from miketalk.mouth import mouth_opening
from miketalk_lab.evaluation.measures import (
    box_mask,
    lag_frames,
    psnr,
    sharpness,
    sharpness_ratio,
    ssim,
)


@pytest.mark.parametrize("shape", [(256, 256, 3), (97, 140, 3), (64, 64)])
def test_ssim_is_scikit_images(shape):
    rng = np.random.default_rng(1)
    a = rng.integers(0, 256, shape, dtype=np.uint8)
    b = np.clip(a + rng.integers(-40, 40, shape), 0, 255).astype(np.uint8)
    channel_axis = -1 if len(shape) == 3 else None
    expected = structural_similarity(a, b, channel_axis=channel_axis, data_range=255)
    assert ssim(a, b) == pytest.approx(expected, abs=1e-12)
    assert ssim(a, a) == pytest.approx(1.0, abs=1e-12)
    mask = np.zeros(shape[:2], bool)
    mask[10:50, 20:60] = True
    crop = (slice(10, 50), slice(20, 60))
    expected = structural_similarity(a[crop], b[crop], channel_axis=channel_axis, data_range=255)
    assert ssim(a, b, mask) == pytest.approx(expected, abs=1e-12)


def test_measure_errors():
    a = np.zeros((8, 8), np.uint8)
    with pytest.raises(MiketalkError, match="shapes differ"):
        ssim(a, np.zeros((8, 9), np.uint8))
    with pytest.raises(MiketalkError, match="at least 7x7"):
        ssim(a[:5], a[:5])
    with pytest.raises(MiketalkError, match="empty"):
        ssim(a, a, np.zeros((8, 8), bool))
    assert psnr(a, a) == float("inf")
    assert psnr(a, a + 255) == pytest.approx(0.0)


def test_sharpness_falls_with_blur_and_reads_the_mask_only():
    rng = np.random.default_rng(3)
    image = cv2.resize(rng.integers(0, 256, (24, 32, 3), dtype=np.uint8), (128, 96))
    flat = np.full_like(image, 90)
    assert sharpness(flat) == 0.0
    # a 1-px step of 10 grey levels: the 3x3 Laplacian is +-10 on the two columns beside it
    step = np.zeros((20, 20), np.uint8)
    step[:, 10:] = 10
    assert sharpness(step) == pytest.approx(2 * 100 / 20)
    sharp = sharpness(image)
    soft = [sharpness(cv2.GaussianBlur(image, (0, 0), s)) for s in (0.5, 1.0, 2.0)]
    assert sharp > soft[0] > soft[1] > soft[2] > 0
    assert soft[0] < 0.8 * sharp  # half a pixel of blur is plain in the measure
    # colour is measured as its grey level; outside the mask nothing counts
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    assert sharpness(image) == pytest.approx(sharpness(grey), rel=0.02)  # grey rounded
    mask = np.zeros(image.shape[:2], bool)
    mask[:, :40] = True
    noisy = image.copy()
    noisy[:, 60:] = rng.integers(0, 256, noisy[:, 60:].shape, dtype=np.uint8)
    assert sharpness(noisy, mask) == sharpness(image, mask)
    assert sharpness(noisy) > sharpness(image)
    # the ratio of a clip's means, over a box given as (x, y, w, h)
    box = box_mask(image.shape, (0, 0, 40, 96))
    assert box.shape == (96, 128) and box.sum() == 40 * 96 and np.array_equal(box, mask)
    blurred = [cv2.GaussianBlur(image, (0, 0), 1.0), image]
    assert sharpness_ratio(blurred, [image, image], box) == pytest.approx(
        (sharpness(blurred[0], box) + sharpness(image, box)) / (2 * sharpness(image, box))
    )
    assert sharpness_ratio([image], [image], box) == 1.0
    assert sharpness_ratio([flat], [flat]) == 0.0  # no detail in either: no division by 0


def test_lag_and_opening():
    t = np.arange(60)
    reference = np.sin(t / 5.0)
    assert lag_frames(np.sin((t - 3) / 5.0), reference) == 3
    assert lag_frames(reference, reference) == 0
    frames = np.zeros((3, 4, 4, 3), np.uint8)
    frames[1, :2] = 255
    frames[2] = 255
    region = np.ones((4, 4), bool)
    assert mouth_opening(frames, region).tolist() == [1.0, 0.5, 0.0]
