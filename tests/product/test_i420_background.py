"""A dubbed video's frames kept in the encoder's colours: decoded as ``yuv420p`` planes, read
as RGB only over the mouth's box (:class:`miketalk.media.yuv.RgbOfI420`), composited there."""

from __future__ import annotations

import subprocess

import cv2
import numpy as np
import pytest

from miketalk.composite.background import Background, composited
from miketalk.composite.compositor import Compositor
from miketalk.media.decode import read_video
from miketalk.media.ffmpeg_log import plain_i420
from miketalk.media.frame_source import RgbFrames, VideoFrames, decodes_to_i420, played
from miketalk.media.video import ffmpeg_exe, write_mp4
from miketalk.media.yuv import I420Frame, RgbOfI420, to_i420

SIZE = (64, 96)  # (H, W)


def _smooth_frames(n: int, seed: int = 0) -> np.ndarray:
    """Colour noise at a few scales, moving from frame to frame (what a camera sees)."""
    rng = np.random.default_rng(seed)
    base = np.zeros((SIZE[0] + n, SIZE[1] + n, 3), np.float32)
    for sigma, gain in ((1.0, 20.0), (3.0, 50.0), (8.0, 90.0)):
        noise = rng.normal(size=base.shape).astype(np.float32)
        base += gain * cv2.GaussianBlur(noise, (0, 0), sigma) * sigma
    base = np.clip(128 + base, 0, 255).astype(np.uint8)
    return np.stack([base[k : k + SIZE[0], k : k + SIZE[1]] for k in range(n)])


def test_a_box_read_of_an_i420_frame_is_that_box_of_the_whole_frames_rgb():
    rng = np.random.default_rng(1)
    for h, w in ((64, 96), (6, 8)):
        planes = rng.integers(0, 256, (h * 3 // 2, w), dtype=np.uint8)
        whole = cv2.cvtColor(planes, cv2.COLOR_YUV2RGB_I420)
        view = RgbOfI420(planes)
        assert view.shape == (h, w, 3)
        assert np.array_equal(np.asarray(view), whole)
        for _ in range(300):  # odd and even corners, empty boxes, boxes reaching the edges
            y0, x0 = int(rng.integers(0, h)), int(rng.integers(0, w))
            y1, x1 = int(rng.integers(y0, h + 1)), int(rng.integers(x0, w + 1))
            assert np.array_equal(view[y0:y1, x0:x1], whole[y0:y1, x0:x1])
        assert np.array_equal(view[1:5, 3:7, 2], whole[1:5, 3:7, 2])
        assert np.array_equal(view[3], whole[3])


def _log_line(pixfmt: str, csp: str, rng: str) -> str:
    return (f"[graph -1 input from stream 0:0 @ 0x55] w:96 h:64 pixfmt:{pixfmt} tb:1/25 "
            f"fr:25/1 sar:1/1 csp:{csp} range:{rng} alpha:unspecified")  # fmt: skip


@pytest.mark.parametrize(
    ("pixfmt", "csp", "rng", "plain"),
    [
        ("yuv420p", "unknown", "unknown", True),
        ("yuv420p", "bt470bg", "tv", True),
        ("yuv420p", "smpte170m", "tv", True),
        ("yuv420p", "bt709", "tv", False),  # another matrix: its RGB is not OpenCV's
        ("yuv420p", "unknown", "pc", False),  # full range
        ("yuvj420p", "unknown", "pc", False),
        ("yuv444p", "unknown", "tv", False),
        ("yuv420p10le", "unknown", "tv", False),
    ],
)
def test_only_8_bit_limited_bt601_420_counts_as_the_encoders_colours(pixfmt, csp, rng, plain):
    assert plain_i420(_log_line(pixfmt, csp, rng)) is plain
    assert plain_i420("no such line") is False


def test_a_yuv420p_videos_planes_are_read_as_decoded_and_its_rgb_where_read(tmp_path):
    """Losslessly encoded planes decode to themselves; the RGB read through them is
    OpenCV's conversion of them, within rounding of ffmpeg's own RGB of the video."""
    rgb = _smooth_frames(8)
    planes = [to_i420(f) for f in rgb]
    path = tmp_path / "v.mp4"
    write_mp4(path, (I420Frame(p) for p in planes), fps=25, n_frames=len(planes), crf=0)
    assert decodes_to_i420(path)
    frames, i420 = played(path, count=len(planes), fps=25.0)
    assert isinstance(frames, RgbFrames) and isinstance(i420, VideoFrames)
    assert frames.shape == (8, *SIZE, 3) and i420.shape == (8, SIZE[0] * 3 // 2, SIZE[1])
    for k in (0, 5, 2):  # and back: the stream reopened
        assert np.array_equal(i420[k], planes[k])
        converted = cv2.cvtColor(planes[k], cv2.COLOR_YUV2RGB_I420)
        assert np.array_equal(frames[k][10:31, 7:50], converted[10:31, 7:50])
    ffmpegs, _ = read_video(path)
    whole = np.stack([np.asarray(f) for f in frames]).astype(np.int16)
    error = whole - ffmpegs  # rounding and chroma interpolation (nearest against bicubic)
    assert np.abs(error).mean() < 3.0 and np.abs(error.mean(axis=(0, 1, 2))).max() < 0.5
    i420.close()


def test_a_video_in_other_colours_plays_as_ffmpegs_rgb(tmp_path):
    path = tmp_path / "v444.mp4"
    raw = _smooth_frames(4)
    subprocess.run(
        [ffmpeg_exe(), "-v", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s",
         f"{SIZE[1]}x{SIZE[0]}", "-r", "25", "-i", "-", "-c:v", "libx264", "-qp", "0",
         "-pix_fmt", "yuv444p", str(path)], input=raw.tobytes(), check=True,
    )  # fmt: skip
    assert not decodes_to_i420(path)
    frames, i420 = played(path, count=4, fps=25.0)
    assert i420 is None and isinstance(frames, VideoFrames)
    assert np.array_equal(frames[1], read_video(path)[0][1])


def test_a_mouth_composited_into_i420_frames_is_the_same_read_lazily_or_whole():
    """The frames read as RGB only over the mouth's box composite to the very planes the
    whole frames converted to RGB give."""
    rgb = _smooth_frames(5, seed=4)
    planes = np.stack([to_i420(f) for f in rgb])
    whole = np.stack([cv2.cvtColor(p, cv2.COLOR_YUV2RGB_I420) for p in planes])
    lazy = [RgbOfI420(p) for p in planes]

    class Lazy(list):
        shape = whole.shape

    transforms = np.stack([np.array([[1.02, 0.03, 3.5 + k], [-0.03, 1.02, -2.2]])
                           for k in range(5)])  # fmt: skip
    render = _smooth_frames(1, seed=9)[0]
    compositor = Compositor((30, 30, 36, 12), SIZE)
    outs = []
    for frames in (whole, Lazy(lazy)):
        background = Background(frames, transforms, None, 25.0, i420=planes)
        outs.append([f.planes for f in composited([render] * 5, background, compositor,
                                                  fps=25.0, i420=True)])  # fmt: skip
    assert all(np.array_equal(a, b) for a, b in zip(*outs, strict=True))
    changed = [np.flatnonzero((a != p).any(axis=1)) for a, p in zip(outs[0], planes, strict=True)]
    assert all(len(c) for c in changed)  # a mouth went in
