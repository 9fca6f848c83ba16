"""Eigenlips: the principal axes of normalized mouth boxes, as an SVD finds them, held once."""

from __future__ import annotations

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.mouth.eigenlips import BLOCK, Eigenlips, centre_darkening, normalized


def _mouths(count: int, box: tuple[int, int], seed: int = 0) -> np.ndarray:
    """Boxes of a few independent patterns of decreasing strength, and noise."""
    rng = np.random.default_rng(seed)
    patterns = rng.normal(size=(5, box[0] * box[1]))
    weights = rng.normal(size=(count, 5)) * [5.0, 3.0, 2.0, 1.0, 0.5]
    flat = weights @ patterns + rng.normal(size=(count, box[0] * box[1]))
    return (100 + 10 * flat).astype(np.float32).reshape(count, *box)


@pytest.mark.parametrize(
    ("count", "box"),
    [(60, (12, 15)), (2 * BLOCK + 37, (9, 11))],  # fewer frames than pixels, and more
)
def test_the_axes_are_the_svds_right_singular_vectors(count, box):
    mouths = _mouths(count, box)
    centred = normalized(mouths)
    centred -= centred.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    fitted = Eigenlips(mouths, n=3)
    # the same axes up to their signs, the same variances and shares of the whole
    np.testing.assert_allclose(np.abs(vt[:3] @ fitted.components.T), np.eye(3), atol=1e-9)
    np.testing.assert_allclose(fitted.variance, s[:3] ** 2 / (count - 1), rtol=1e-9)
    np.testing.assert_allclose(fitted.explained, s[:3] ** 2 / (s**2).sum(), rtol=1e-9)
    # projected a block at a time, as the whole matrix would be
    np.testing.assert_allclose(
        fitted.project(mouths), (normalized(mouths) - fitted.mean) @ fitted.components.T,
        rtol=1e-9, atol=1e-9,
    )  # fmt: skip


def test_the_first_axis_points_the_way_the_mouth_opens():
    """Boxes whose centre darkens by a random amount: the first coefficient rises with it."""
    rng = np.random.default_rng(2)
    h, w = 16, 24
    dark = -centre_darkening((h, w)).reshape(h, w)  # bright centre, dark edges
    opening = rng.uniform(0, 1, 80)
    texture = rng.normal(size=(h, w))
    mouths = 120 + 5 * texture - 40 * opening[:, None, None] * dark[None] / np.abs(dark).max()
    mouths += rng.normal(scale=0.5, size=mouths.shape)
    fitted = Eigenlips(mouths.astype(np.float32), n=2)
    first = fitted.project(mouths)[:, 0]
    assert np.corrcoef(first, opening)[0, 1] > 0.9
    # the same whichever way the frames come
    again = Eigenlips(mouths[::-1].astype(np.float32), n=2)
    assert np.corrcoef(again.project(mouths)[:, 0], opening)[0, 1] > 0.9


def test_too_few_frames_are_refused():
    with pytest.raises(MiketalkError, match="more than 3 training frames"):
        Eigenlips(_mouths(3, (6, 6)), n=3)
