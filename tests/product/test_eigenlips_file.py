"""A corpus's eigenlips fitted once, written, read back: the same arrays as fitting them again."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from miketalk.corpus.eigenlips import (
    corpus_mouths,
    fit_corpus_eigenlips,
    read_eigenlips,
    write_eigenlips,
)
from miketalk.corpus.folder import frame_path
from miketalk.media.images import write_png
from miketalk.mouth import Eigenlips


def small_corpus(root: Path, n: int = 40) -> Path:
    """Frames of a mouth that opens and closes (a dark ellipse of varying height) in noise."""
    rng = np.random.default_rng(3)
    (root / "frames").mkdir(parents=True)
    size = (72, 96)
    for k in range(n):
        frame = np.full((*size, 3), 180, np.uint8)
        frame += rng.integers(0, 20, frame.shape, dtype=np.uint8)
        yy, xx = np.mgrid[: size[0], : size[1]]
        opening = 2 + 8 * abs(np.sin(k / 4))
        inside = ((xx - 48) / 14) ** 2 + ((yy - 40) / opening) ** 2 < 1
        frame[inside] = 40
        write_png(frame_path(root / "frames", k), frame)
    regions = {"mouth_box": [34, 36, 28, 8], "size": list(size)}
    (root / "regions.json").write_text(json.dumps(regions))
    return root


def test_written_eigenlips_are_the_fitted_ones(tmp_path: Path) -> None:
    corpus = small_corpus(tmp_path / "corpus")
    fitted = fit_corpus_eigenlips(corpus)
    direct = Eigenlips(corpus_mouths(corpus))  # as the held-out stage fitted them
    for name in ("mean", "components", "variance", "explained"):
        assert np.array_equal(getattr(fitted.eigenlips, name), getattr(direct, name)), name
    write_eigenlips(tmp_path / "eigenlips.npz", fitted)
    back = read_eigenlips(tmp_path / "eigenlips.npz")
    for name in ("mean", "components", "variance", "explained"):
        assert np.array_equal(getattr(back.eigenlips, name), getattr(direct, name)), name
    assert np.array_equal(back.coordinates, direct.project(corpus_mouths(corpus)))
    assert back.coordinates.shape == (40, 3)
    # the opening is what varies most: the first coefficient follows it
    opening = np.abs(np.sin(np.arange(40) / 4))
    assert abs(np.corrcoef(back.coordinates[:, 0], opening)[0, 1]) > 0.9
