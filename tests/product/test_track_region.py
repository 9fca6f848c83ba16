"""A video's two readings for its face crops: grey frames for the tracker (the luma plane,
ffmpeg's grey conversion byte for byte), and in RGB only the part of the frames the crops
see; the crops are the whole frames' crops (by the same conversion), byte for byte."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.media.decode import iter_video_frames, read_video
from miketalk.track.canonical import CANONICAL_LANDMARKS
from miketalk.track.crop import FaceCropSettings
from miketalk.track.resample import source_bounds
from miketalk.track.similarity import apply_affine, invert_affine
from miketalk.track.track import FaceTracker, track_frames
from miketalk.track.video_crops import REGION_MARGIN, crop_region, crop_video, crops_of

CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"


@pytest.fixture(scope="module")
def s1() -> np.ndarray:
    frames, _ = read_video(CLIP, frames=12)
    return frames


def test_grey_frames_are_the_rgb_frames_luma(s1: np.ndarray) -> None:
    grey = np.stack(list(iter_video_frames(CLIP, frames=12, grey=True)))
    assert grey.shape == s1.shape[:3] and grey.dtype == np.uint8
    expected = np.stack([cv2.cvtColor(f, cv2.COLOR_RGB2GRAY) for f in s1]).astype(int)
    difference = np.abs(grey.astype(int) - expected)
    unclipped = (s1 < 250).all(axis=3) & (s1 > 5).all(axis=3)  # GRID's blue is clipped in RGB
    assert difference[unclipped].mean() < 0.5 and difference[unclipped].max() <= 2


def test_a_region_is_the_whole_frames_part_away_from_its_edges(s1: np.ndarray) -> None:
    x, y, w, h = 100, 60, 150, 120  # even (an odd width or height shifts MPEG-1's chroma)
    part = np.stack(list(iter_video_frames(CLIP, frames=12, region=(x, y, w, h))))
    assert part.shape == (12, h, w, 3)
    m = 3  # ffmpeg interpolates the chroma from inside the region only
    assert np.array_equal(
        part[:, m : h - m, m : w - m], s1[:, y + m : y + h - m, x + m : x + w - m]
    )
    corner = np.stack(list(iter_video_frames(CLIP, frames=12, region=(0, 0, 100, 80))))
    assert np.array_equal(corner[:, :77, :97], s1[:, :77, :97])  # the frame's own edges too


def test_the_crop_region_holds_every_crops_window_and_is_even() -> None:
    settings = FaceCropSettings()
    size = (1920, 1080)
    to_crop = np.stack(
        [np.array([[0.5, 0.05, -400.0 - 4 * k], [-0.05, 0.5, -150.0 + 3 * k]]) for k in range(9)]
    )
    x, y, w, h = crop_region(to_crop, settings, size)
    assert (x % 2, y % 2, w % 2, h % 2) == (0, 0, 0, 0)
    assert x + w <= size[0] and y + h <= size[1]
    for t in to_crop:
        x0, y0, x1, y1 = source_bounds((size[1], size[0]), t, (settings.size, settings.size))
        assert x <= x0 - REGION_MARGIN and y <= y0 - REGION_MARGIN
        assert x1 + REGION_MARGIN <= x + w and y1 + REGION_MARGIN <= y + h
    assert w * h < 0.2 * size[0] * size[1]  # a still face's, not the frame
    whole = np.array([[[0.1, 0.0, 0.0], [0.0, 0.1, 0.0]]])  # sees all of a 1920x1080 frame
    assert crop_region(whole, settings, size) is None
    # a region that would end on an odd-sized frame's edge: the whole frame
    assert crop_region(to_crop, settings, (1919, 1079)) is not None
    moved = to_crop + np.array([[0.0, 0.0, -350.0], [0.0, 0.0, 0.0]])  # to the right edge
    assert crop_region(moved, settings, (1919, 1080)) is None


@pytest.mark.parametrize("conversion", ["accurate", "fast"])
def test_the_crops_read_from_the_region_are_the_whole_frames_crops(
    conversion: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    from miketalk.media import decode

    read, real = [], decode.iter_video_frames
    monkeypatch.setattr(decode, "iter_video_frames", lambda *a, **k: (
        read.append(k.get("region")) or real(*a, **k)))  # fmt: skip
    settings = FaceCropSettings(conversion=conversion)
    cropped = crop_video(CLIP, frames=20, crop=settings)
    frames = iter_video_frames(CLIP, frames=20, conversion=conversion)
    # the colour frames were read as the region only (the tracker's grey ones whole)
    assert read == [None, crop_region(cropped.to_crop, settings, cropped.size)]
    assert read[1] is not None and read[1][2] * read[1][3] < 360 * 288
    expected = crops_of(frames, cropped.to_crop, settings, 20)
    assert np.array_equal(cropped.crops, expected)


def test_auto_converts_fast_only_where_each_crop_pixel_averages_several() -> None:
    from miketalk.track.crop import chosen_conversion

    auto, crop = FaceCropSettings(), FaceCropSettings().size ** 2
    assert chosen_conversion(auto, 706 * 648) == "fast"  # s1's face at 1080p: 7x the crop
    assert chosen_conversion(auto, 2 * crop) == "fast"
    assert chosen_conversion(auto, 2 * crop - 1) == "accurate"
    assert chosen_conversion(auto, 176 * 176) == "accurate"  # s1's at 360x288: enlarged
    for own in ("fast", "accurate"):
        assert chosen_conversion(FaceCropSettings(conversion=own), 10**7) == own
    s1 = crop_video(CLIP, frames=4)  # auto, 360x288: the accurate crops, as before
    assert np.array_equal(s1.crops, crop_video(CLIP, frames=4, crop=FaceCropSettings(
        conversion="accurate")).crops)  # fmt: skip


def test_the_fast_conversion_is_within_a_few_levels_of_the_accurate_one(s1) -> None:
    fast = np.stack(list(iter_video_frames(CLIP, frames=12, conversion="fast")))
    difference = s1.astype(int) - fast.astype(int)
    assert not np.array_equal(fast, s1)  # another conversion...
    # ...close: 1.1 levels darker on average, 3 at the 95th percentile (9 at the 99th, in
    # GRID's saturated blue and at strong colour edges)
    assert abs(difference.mean()) < 2 and np.percentile(np.abs(difference), 95) <= 4


def _yuv_video(path: Path, pix_fmt: str, codec: list[str]) -> None:
    """Every luma value 0-255 in a few frames of ``pix_fmt``, stored losslessly."""
    import subprocess

    import imageio_ffmpeg

    ramp = np.tile(np.arange(256, dtype=np.uint8), (16, 1))  # 16 rows of 0..255
    frames = np.stack([np.roll(ramp, 7 * k, axis=1) for k in range(4)])
    rgb = np.repeat(frames[..., None], 3, axis=3)  # grey ramps: every luma level...
    rgb[:, 8:, :, 0] = 255 - rgb[:, 8:, :, 0]  # ...and colour below them (chroma not flat)
    subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-y", "-f", "rawvideo",
         "-pix_fmt", "rgb24", "-s", "256x16", "-r", "25", "-i", "pipe:0", *codec,
         "-pix_fmt", pix_fmt, str(path)],
        input=rgb.tobytes(), check=True,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("pix_fmt", "codec", "kind"),
    [
        ("yuv420p", ["-c:v", "ffv1"], "tv"),
        ("yuvj420p", ["-c:v", "mjpeg", "-q:v", "2"], "pc"),
        ("yuv444p", ["-c:v", "ffv1"], "tv"),
        ("rgb24", ["-c:v", "ffv1"], None),  # not planar YUV: ffmpeg converts
    ],
)
def test_grey_frames_taken_from_the_luma_plane_are_ffmpegs_grey_conversion(
    tmp_path: Path, pix_fmt: str, codec: list[str], kind: str | None
) -> None:
    from miketalk.media import decode

    video = tmp_path / "ramp.mkv"
    _yuv_video(video, pix_fmt, codec)
    taken = list(iter_video_frames(video, grey=True))
    key = decode._file_key(video)
    assert decode._logged[key].luma == kind
    decode._logged[key] = decode._logged[key]._replace(luma=None)  # ffmpeg's grey conversion
    converted = list(iter_video_frames(video, grey=True))
    assert len(taken) == len(converted) == 4
    assert all(np.array_equal(a, b) for a, b in zip(taken, converted, strict=True))
    values = np.unique(np.concatenate([c.ravel() for c in converted]))
    if kind == "tv":
        assert len(values) > 200  # most of the 220 limited-range levels were compared


def test_the_tracker_follows_grey_frames_as_rgb_ones(s1: np.ndarray) -> None:
    grey = [cv2.cvtColor(f, cv2.COLOR_RGB2GRAY) for f in s1]
    a, b = track_frames(s1, fps=25.0), track_frames(grey, fps=25.0)
    assert a.tracked.all() and b.tracked.all()
    for ta, tb in zip(a.transforms, b.transforms, strict=True):
        pa = apply_affine(invert_affine(ta), CANONICAL_LANDMARKS)
        pb = apply_affine(invert_affine(tb), CANONICAL_LANDMARKS)
        assert np.sqrt(((pa - pb) ** 2).sum(axis=1).mean()) < 0.5  # pixels (s1: ~0.1)
    tracker = FaceTracker(fps=25.0)
    for bad in (np.zeros((8, 8, 4), np.uint8), np.zeros((8, 8), np.float32), np.zeros(8, np.uint8)):
        with pytest.raises(MiketalkError, match="a frame must be"):
            tracker.update(bad)


def test_a_files_video_info_is_found_once(tmp_path: Path, monkeypatch) -> None:
    import os
    import shutil

    from miketalk.media import decode

    clip = tmp_path / "clip.mpg"
    shutil.copy(CLIP, clip)
    calls = []
    real = decode.read_video
    monkeypatch.setattr(decode, "read_video", lambda *a, **k: calls.append(a) or real(*a, **k))
    assert decode.video_info(clip) == (360, 288, 25.0)
    assert decode.video_info(clip) == (360, 288, 25.0) and len(calls) == 1
    os.utime(clip, ns=(10**9, 10**9))  # another version of the file: read again
    assert decode.video_info(clip) == (360, 288, 25.0) and len(calls) == 2
    with pytest.raises(MiketalkError, match="not found"):
        decode.video_info(tmp_path / "none.mp4")
