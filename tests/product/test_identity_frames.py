"""The identity check's frames in one decoding pass (:mod:`miketalk.track.sampled_frames`):
the same frames as a seek to each time, taken in one pass where the video's keyframes are far
apart (x264's default), by seeks where they are near."""

from __future__ import annotations

import subprocess
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from miketalk.media.decode import read_video
from miketalk.stabilize.faces import SAMPLES
from miketalk.track import sampled_frames as sf


def _h264(path: Path, keyint: int, seconds: float = 4.0) -> Path:
    """A moving test picture in H.264, a keyframe every ``keyint`` frames."""
    subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-nostdin",
            "-f", "lavfi", "-i", f"testsrc2=size=160x120:rate=25:duration={seconds}",
            "-c:v", "libx264", "-preset", "ultrafast", "-g", str(keyint),
            "-keyint_min", str(keyint), "-sc_threshold", "0", "-pix_fmt", "yuv420p", str(path),
        ],
        check=True,
    )  # fmt: skip
    return path


def _counted(monkeypatch) -> list[Path]:
    passes: list[Path] = []
    one_pass = sf._one_pass

    def counted(video, times):
        passes.append(video)
        return one_pass(video, times)

    monkeypatch.setattr(sf, "_one_pass", counted)
    return passes


TIMES = (np.arange(SAMPLES) + 0.5) * 4.0 / SAMPLES


@pytest.mark.parametrize("keyint, passes", [(250, 1), (5, 0)])
def test_the_same_frames_in_one_pass_where_it_decodes_less(tmp_path, monkeypatch, keyint, passes):
    video = _h264(tmp_path / f"k{keyint}.mp4", keyint)
    every, fps = read_video(video)
    assert fps == 25.0 and len(every) == 100
    seen = _counted(monkeypatch)
    got = sf.sampled_frames(video, TIMES)
    assert len(seen) == passes  # one keyframe: a pass; one every 5 frames: seeks
    seeks = sf.sampled_frames(video, TIMES, how=sf.SEEKS)
    forced = sf.sampled_frames(video, TIMES, how=sf.PASS)
    assert len(seen) == passes + 1
    # the first frame shown at or after each time, each way, byte for byte
    first = np.ceil(TIMES * fps - 1e-9).astype(int)
    assert len(got) == len(seeks) == len(forced) == SAMPLES
    for i, k in enumerate(first):
        assert np.array_equal(got[i], every[k]), i
        assert np.array_equal(seeks[i], every[k]) and np.array_equal(forced[i], every[k]), i
    counts = sf.decoded_frames(sf._packets(video), TIMES, fps)
    assert counts is not None and (counts[sf.PASS] <= counts[sf.SEEKS]) == bool(passes)


def test_times_past_the_end_give_the_frames_before_them(tmp_path):
    video = _h264(tmp_path / "short.mp4", 250, seconds=2.0)
    every, _ = read_video(video)
    times = [0.5, 1.5, 3.0, 3.5]  # the last two past the stream's end
    for how in (sf.PASS, sf.SEEKS, "auto"):
        got = sf.sampled_frames(video, times, how=how)
        assert len(got) == 2, how
        assert np.array_equal(got[0], every[13]) and np.array_equal(got[1], every[38]), how


def test_times_closer_than_a_frame_and_a_half_are_read_by_seeks():
    packets = [(k / 25, k == 0) for k in range(100)]
    assert sf.decoded_frames(packets, [0.5, 0.52, 3.0], 25.0) is None
    # frames 13, 25 and 75; from the one keyframe, frame 0
    assert sf.decoded_frames(packets, [0.5, 1.0, 3.0], 25.0) == {sf.PASS: 76, sf.SEEKS: 116}
    uneven = [(k / 25 + (0.03 if k > 50 else 0), k == 0) for k in range(100)]  # not its rate
    assert sf.decoded_frames(uneven, [0.5, 1.0, 3.0], 25.0) is None
