"""The lag of a video's sound behind its mouth: measured, kept, and used (issue 52)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from miketalk.corpus import sound_lag as sound_lag_module
from miketalk.corpus.clip_sources import _lagged
from miketalk.corpus.sound_lag import (
    KEY,
    MAX_LAG_FRAMES,
    lag_of_curves,
    led,
    model_sound_lag,
    sound_lag,
)
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming

DATA = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video"


def _smooth(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.convolve(rng.normal(size=n + 8), np.ones(5) / 5, mode="same")[4 : n + 4]


@pytest.mark.parametrize("late", [0, 2, -2])
def test_the_lag_is_found_where_the_sound_follows_the_mouth(
    late: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sound_lag_module, "APPLY", True)
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
    monkeypatch.setattr(sound_lag_module, "APPLY", False)  # the default: measured, not kept
    off = lag_of_curves(openings, envelopes, fps=25.0)
    assert off.seconds == 0.0 and off.peak_frames == got.peak_frames


def test_no_lag_is_kept_from_noise_or_at_the_edge_of_the_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(sound_lag_module, "APPLY", True)
    rng = np.random.default_rng(2)
    noise = lag_of_curves([rng.normal(size=90)], [rng.normal(size=90)], fps=25.0)
    assert noise.seconds == 0.0 and noise.peak_r < 0.2
    mouth = _smooth(rng, 120)
    edge = MAX_LAG_FRAMES + 2
    far = lag_of_curves([mouth[10:100]], [mouth[10 - edge : 100 - edge]], fps=25.0)
    assert far.seconds == 0.0


def test_a_recordings_phones_lead_and_its_sound_follows() -> None:
    phones = [Phone("pau", 0.0, 0.3), Phone("b", 0.3, 0.4), Phone("aa", 0.4, 0.7),
              Phone("pau", 0.7, 1.0)]  # fmt: skip
    samples = np.arange(16000, dtype=np.int16)
    moved, heard = led(phones, samples, 16000, 0.1, 1.0)
    assert [p.name for p in moved] == ["pau", "b", "aa", "pau"]
    assert moved[0].start == 0.0 and moved[-1].end == 1.0
    assert moved[1].start == pytest.approx(0.2) and moved[2].end == pytest.approx(0.6)
    assert heard[0] == 1600 and len(heard) == len(samples) and heard[-1] == 0
    later, behind = led(phones, samples, 16000, -0.1, 1.0)
    assert later[1].start == pytest.approx(0.4) and behind[1600] == 0 and behind[0] == 0
    same, sound = led(phones, samples, 16000, 0.0, 1.0)
    assert same == phones and sound is samples


def test_the_words_of_a_lagged_clip_come_as_much_earlier() -> None:
    words = (WordTiming("bin", 0.05, 0.3), WordTiming("blue", 0.3, 0.6))
    got = _lagged(words, 0.1)
    assert got[0].start == 0.0 and got[0].end == pytest.approx(0.2)
    assert got[1].start == pytest.approx(0.2) and got[1].end == pytest.approx(0.5)
    assert _lagged(words, 0.0) == list(words)


def test_a_model_keeps_its_lag_in_its_segments(tmp_path: Path) -> None:
    assert model_sound_lag(tmp_path) == 0.0
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "segments.json").write_text(json.dumps({KEY: 0.067}), "utf-8")
    assert model_sound_lag(tmp_path) == 0.067


def test_a_video_whose_sound_was_delayed_is_measured_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two s1 clips (GRID: sound and mouth together) keep no lag; the same clips with their
    sound delayed by 3 frames measure 3 frames more (within half a frame) and keep it."""
    from miketalk.media.decode import read_media_audio, read_video
    from miketalk.media.video import write_mp4

    monkeypatch.setattr(sound_lag_module, "APPLY", True)
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
    assert got[0].seconds == 0.0 and abs(got[0].peak_frames) < 1
    none = sound_lag(tmp_path / "late0.mp4", [])  # no utterance long enough: no lag, no error
    assert none.seconds == 0.0 and none.frames == 0
    assert abs(got[3].peak_frames - got[0].peak_frames - 3) < 0.5
    assert got[3].seconds == pytest.approx(got[3].peak_frames / 25)


def _trained_face(model: Path, r2: float | None) -> Path:
    """A model folder with a trained face whose build measured ``r2`` (None: no measure)."""
    (model / "trained").mkdir(parents=True)
    fit = {"frames": 415, "clips": 8}
    if r2 is not None:
        fit |= {"window": {"cv_r2": [0.5, 0.1]}, "heard": {"cv_r2": [0.0, r2, 0.02]}}
    doc = {"format": "miketalk-trained/1", "default": "window", "fit": fit,
           "trajectories": {"window": {}, "heard": {}}}  # fmt: skip
    (model / "trained" / "trained.json").write_text(json.dumps(doc), "utf-8")
    (model / "coarticulation.json").write_text("{}", "utf-8")
    return model


def test_a_trained_face_that_predicts_nothing_leaves_recordings_to_the_morph(
    tmp_path: Path,
) -> None:
    from miketalk.model.parts import choose_lipsync_model, default_lipsync_model, trained_predicts

    weak = _trained_face(tmp_path / "weak", 0.0)
    strong = _trained_face(tmp_path / "strong", 0.42)
    old = _trained_face(tmp_path / "old", None)
    assert trained_predicts(weak) == (False, 0.02)  # its best component
    assert trained_predicts(strong) == (True, 0.42)
    assert trained_predicts(old) == (True, None)
    assert default_lipsync_model(weak, recorded=True) == "paper"
    assert default_lipsync_model(strong, recorded=True) == "trained"
    assert default_lipsync_model(old, recorded=True) == "trained"
    assert default_lipsync_model(weak, recorded=False) == "learned"  # typed text: unchanged
    assert choose_lipsync_model(weak, None, recorded=True).value == "paper"
    # what is asked for is drawn
    assert choose_lipsync_model(weak, "trained", recorded=True).value == "trained"
    assert choose_lipsync_model(weak, None, trajectory="heard", recorded=True).value == "trained"
