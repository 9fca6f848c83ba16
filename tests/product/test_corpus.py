"""A person's recording brought into the corpus layout: decoding, cropping, scaling, errors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.corpus.ingest import ingest_video
from miketalk.errors import MiketalkError
from miketalk.media.images import read_image
from miketalk.media.video import write_mp4
from miketalk.speech import FestivalBackend

pytestmark = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival with voice_kal_diphone not installed"
)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    """An 80x60 mp4 with sound: smooth moving blobs, so scaling is measurable."""
    ys, xs = np.mgrid[0:60, 0:80].astype(np.float32)
    frames = []
    for k in range(12):
        blob = np.exp(-((xs - 20 - 3 * k) ** 2 + (ys - 30) ** 2) / 60.0)
        grey = 40 + 180 * blob + 0.8 * xs
        frames.append(np.stack([grey, grey[::-1], 255 - grey], -1).clip(0, 255).astype(np.uint8))
    path = tmp_path_factory.mktemp("video") / "person.mp4"
    tone = (3000 * np.sin(np.arange(8000) * 0.05)).astype(np.int16)
    write_mp4(path, frames, fps=20, audio=tone, rate=16000, crf=0)
    return path, np.stack(frames)


def test_whole_frames_by_default(recording: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    video, frames = recording
    ingest_video(video, tmp_path, words=["pat"], backend=FestivalBackend())
    first = read_image(tmp_path / "frames" / "000000.png")
    assert first.shape == (60, 80, 3)
    assert len(list((tmp_path / "frames").glob("*.png"))) == len(frames)
    assert json.loads((tmp_path / "words.json").read_text())["size"] == [60, 80]


def test_crop_and_scale(recording: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    video, frames = recording
    ingest_video(
        video, tmp_path, words=["pat"], backend=FestivalBackend(), crop=[10, 6, 40, 30], width=20
    )
    got = read_image(tmp_path / "frames" / "000005.png")
    assert got.shape == (16, 20, 3)  # 30 * 20 / 40 = 15 rows, rounded to even
    want = cv2.resize(frames[5][6:36, 10:50], (20, 16), interpolation=cv2.INTER_AREA)
    assert np.abs(got.astype(int) - want).mean() < 4  # x264 at crf 0 in yuv420p
    assert json.loads((tmp_path / "words.json").read_text())["size"] == [16, 20]


@pytest.mark.parametrize(
    ("crop", "width", "match"),
    [
        ([70, 0, 20, 20], None, "does not fit the 80x60 recording"),
        ([0, 0, 8, 8], None, "does not fit"),
        ([0, 0, 20], None, "four integers"),
        (None, 4, "video_width must be an integer >= 16"),
    ],
)
def test_bad_crop_or_width_is_a_clear_error(
    recording: tuple[Path, np.ndarray], tmp_path: Path, crop, width, match
) -> None:
    with pytest.raises(MiketalkError, match=match):
        ingest_video(
            recording[0], tmp_path / "out", words=["pat"], backend=FestivalBackend(),
            crop=crop, width=width,
        )  # fmt: skip
    assert not list((tmp_path / "out" / "frames").glob("*.png"))
