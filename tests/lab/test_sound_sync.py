"""How late a video's sound runs behind its mouth, measured in the evaluation (issue 52)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from miketalk.corpus import sound_lag as recorded
from miketalk_lab.evaluation.sound_sync import (
    MAX_LAG_FRAMES,
    lag_of_curves,
    measure_sound_lag,
    sound_lag,
)

DATA = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video"


def _smooth(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.convolve(rng.normal(size=n + 8), np.ones(5) / 5, mode="same")[4 : n + 4]


@pytest.mark.parametrize("late", [0, 2, -2])
def test_the_lag_is_found_where_the_sound_follows_the_mouth(
    late: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(recorded, "APPLY", True)
    rng = np.random.default_rng(1)
    openings, envelopes = [], []
    for n in (60, 80, 70):
        mouth = _smooth(rng, n + 10)
        openings.append(mouth[5 : n + 5])
        envelopes.append(mouth[5 - late : n + 5 - late] + 0.2 * rng.normal(size=n))
    got = lag_of_curves(openings, envelopes, fps=25.0)
    assert round(got.peak_frames) == late
    assert got.seconds == (pytest.approx(got.peak_frames / 25.0) if late else 0.0)
    assert got.peak_r > 0.8
    monkeypatch.setattr(recorded, "APPLY", False)  # the default: measured, not kept
    off = lag_of_curves(openings, envelopes, fps=25.0)
    assert off.seconds == 0.0 and off.peak_frames == got.peak_frames


def test_no_lag_is_kept_from_noise_or_at_the_edge_of_the_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(recorded, "APPLY", True)
    rng = np.random.default_rng(2)
    noise = lag_of_curves([rng.normal(size=90)], [rng.normal(size=90)], fps=25.0)
    assert noise.seconds == 0.0 and noise.peak_r < 0.2
    mouth = _smooth(rng, 120)
    edge = MAX_LAG_FRAMES + 2
    far = lag_of_curves([mouth[10:100]], [mouth[10 - edge : 100 - edge]], fps=25.0)
    assert far.seconds == 0.0


def test_a_video_whose_sound_was_delayed_is_measured_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two s1 clips (GRID: sound and mouth together) keep no lag; the same clips with their
    sound delayed by 3 frames measure 3 frames more (within half a frame) and keep it, over
    the spans given or a segments file's training utterances."""
    from miketalk.media.decode import read_media_audio, read_video
    from miketalk.media.video import write_mp4

    monkeypatch.setattr(recorded, "APPLY", True)
    clips = [DATA / "bbas3a.mpg", DATA / "bbaf2n.mpg"]
    frames = [read_video(c)[0] for c in clips]
    sound = [read_media_audio(c, rate=16000) for c in clips]
    both = np.concatenate(frames)
    spans = [(0, len(frames[0])), (len(frames[0]), len(frames[1]))]
    got = {}
    for delay in (0, 3):
        pad = round(delay * 16000 / 25)
        audio = np.concatenate([np.pad(s[: len(f) * 640], (0, max(0, len(f) * 640 - len(s))))
                                for s, f in zip(sound, frames, strict=True)])  # fmt: skip
        audio = np.concatenate([np.zeros(pad, np.int16), audio[: len(audio) - pad]])
        video = tmp_path / f"late{delay}.mp4"
        write_mp4(video, iter(both), fps=25, audio=audio, rate=16000, n_frames=len(both))
        got[delay] = sound_lag(video, spans)
    # a built model's training utterances (a held-out one first: too short to measure,
    # counted, it would end the measure at once)
    utterances = [{"split": "test", "first_frame": 0, "frames": 2}] + [
        {"split": "train", "first_frame": a, "frames": n} for a, n in spans
    ]
    segments = tmp_path / "segments.json"
    segments.write_text(json.dumps({"utterances": utterances}), "utf-8")
    trained = measure_sound_lag(tmp_path / "late3.mp4", segments)
    assert trained == got[3] and trained.frames > 100
    assert got[0].seconds == 0.0 and abs(got[0].peak_frames) < 1
    none = sound_lag(tmp_path / "late0.mp4", [])  # no utterance long enough: no lag, no error
    assert none.seconds == 0.0 and none.frames == 0
    assert abs(got[3].peak_frames - got[0].peak_frames - 3) < 0.5
    assert got[3].seconds == pytest.approx(got[3].peak_frames / 25)
