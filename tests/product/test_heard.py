"""The heard trajectory: the recording's log-mel window beside the phones (speech.acoustic)."""

from __future__ import annotations

import numpy as np
import pytest

from miketalk.draw.trained.training import TrainingSet
from miketalk.draw.trained.trajectory import Context, fit_window
from miketalk.errors import MiketalkError
from miketalk.speech.acoustic import RATE, Recording, heard_features
from miketalk.speech.festival.backend import FestivalBackend
from miketalk.speech.types import Phone
from miketalk.visemes import VisemeTable

FPS = 25.0
VOWELS = ("aa", "iy", "uw")


def _stressed_clip(rng: np.random.Generator) -> tuple[tuple[Phone, ...], np.ndarray, Recording]:
    """A clip whose mouth opening is its vowel's times a random stress the phones do not
    name, and whose sound is as loud as the stress: ``(phones, opening per frame, sound)``."""
    t, phones, stress = 0.2, [Phone("pau", 0.0, 0.2)], []
    for _ in range(6):
        for name in ("m", str(rng.choice(VOWELS))):
            d = 0.08 if name == "m" else float(rng.uniform(0.12, 0.2))
            phones.append(Phone(name, t, t + d))
            stress.append(0.0 if name == "m" else float(rng.uniform(0.2, 1.0)))
            t += d
    phones.append(Phone("pau", t, t + 0.2))
    duration = t + 0.2
    times = np.arange(round(duration * FPS)) / FPS
    idx = np.clip(np.searchsorted([p.start for p in phones], times, side="right") - 1, 0, None)
    level = np.array([0.0, *stress, 0.0])[idx]
    opening = 8.0 * level
    n = round(duration * RATE)
    sample_level = np.array([0.0, *stress, 0.0])[
        np.clip(
            np.searchsorted([p.start for p in phones], np.arange(n) / RATE, "right") - 1, 0, None
        )
    ]
    tone = np.sin(2 * np.pi * 220 * np.arange(n) / RATE) + 0.3 * rng.standard_normal(n)
    sound = (3000 * sample_level * tone + 30 * rng.standard_normal(n)).astype(np.int16)
    return tuple(phones), opening[:, None], Recording(sound, RATE)


def _training_set(n_clips: int, seed: int) -> TrainingSet:
    rng = np.random.default_rng(seed)
    clips = [_stressed_clip(rng) for _ in range(n_clips)]
    return TrainingSet(
        tuple(c[0] for c in clips),
        tuple(np.arange(len(c[1])) / FPS for c in clips),
        tuple(c[1] for c in clips),
        tuple(c[2] for c in clips),
    )


def test_heard_features_do_not_change_with_loudness_or_sample_rate() -> None:
    rng = np.random.default_rng(0)
    _, _, sound = _stressed_clip(rng)
    times = np.arange(40) / FPS
    quiet = Recording(sound.samples.astype(np.float32) / 4, RATE)
    a = heard_features(sound, times, half=2, step=0.02)
    assert a.shape == (40, 5 * 24)
    assert np.abs(a - heard_features(quiet, times, half=2, step=0.02)).max() < 0.05
    half_rate = Recording(sound.samples[::2], RATE // 2)  # 8 kHz: resampled to 16 kHz
    b = heard_features(half_rate, times, half=2, step=0.02)
    low = slice(0, 16)  # the bands under 4 kHz survive the lower rate
    assert np.corrcoef(a[:, low].ravel(), b[:, low].ravel())[0, 1] > 0.9


def test_the_heard_trajectory_predicts_what_the_phones_cannot() -> None:
    """The opening scales with a stress only the sound carries: hearing it predicts the
    held-out opening far better than the phone window; a silent recording adds nothing."""
    data = _training_set(15, seed=1)
    table = VisemeTable()
    seen = sorted({p.name for clip in data.phones for p in clip})
    context = Context(tuple(seen), tuple(table.visemes))
    window, window_report = fit_window(data, context, table, half=3)
    heard, heard_report = fit_window(data, context, table, half=3, heard=4)
    assert heard.heard == 4 and window.heard == 0
    assert heard_report["cv_r2"][0] > window_report["cv_r2"][0] + 0.1
    assert heard_report["cv_r2"][0] > 0.8
    new = _training_set(3, seed=2)
    for phones, times, truth, sound in zip(
        new.phones, new.times, new.coords, new.recordings, strict=True
    ):
        by_ear = heard.predict(phones, times, table, sound)[:, 0]
        by_phone = window.predict(phones, times, table)[:, 0]
        assert np.corrcoef(by_ear, truth[:, 0])[0, 1] > 0.9
        assert np.corrcoef(by_ear, truth[:, 0])[0, 1] > np.corrcoef(by_phone, truth[:, 0])[0, 1]
    with pytest.raises(MiketalkError, match="recording"):
        heard.predict(new.phones[0], new.times[0], table)
    silent = TrainingSet(data.phones, data.times, data.coords)
    with pytest.raises(MiketalkError, match="recordings"):
        fit_window(silent, context, table, half=3, heard=4)


def test_another_voice_follows_the_persons_phone_timing() -> None:
    """The voice's phones take the person's durations: one by one where the two match (the
    same phone or another pronunciation), a moment for a phone only the voice speaks, and
    the time of one only the person spoke goes to the phone before it."""
    from miketalk_lab.bench.other_voice import EXTRA_PHONE, retimed_durations

    table = VisemeTable()
    person = [Phone("pau", 0.0, 0.5), Phone("s", 0.5, 0.6), Phone("hh", 0.6, 0.65),
              Phone("w", 0.65, 0.75), Phone("ah", 0.75, 0.9), Phone("n", 0.9, 1.0),
              Phone("pau", 1.0, 1.4)]  # fmt: skip
    voice = ["pau", "s", "w", "ax", "n", "t", "pau"]
    durations = retimed_durations(voice, person, table)
    assert np.allclose(durations, [0.5, 0.15, 0.1, 0.15, 0.1, EXTRA_PHONE, 0.4])
    same = retimed_durations([p.name for p in person], person, table)
    assert np.allclose(same, [p.duration for p in person])


def test_held_out_features_can_differ_from_the_fitted_ones() -> None:
    """cross_validated_r2's held_xs: the model fitted on xs meets other features for the
    held-out clips (another voice): the same features score as before, noise does not."""
    from miketalk_lab.bench.trajectory_cv import cross_validated_r2, ridge_fit

    rng = np.random.default_rng(3)
    xs = [rng.normal(size=(30, 4)) for _ in range(10)]
    w = rng.normal(size=(4, 2))
    ys = [x @ w + 0.05 * rng.normal(size=(30, 2)) for x in xs]
    fit = ridge_fit(1e-3)
    same = cross_validated_r2(xs, ys, fit, held_xs=xs)[0]
    assert same == cross_validated_r2(xs, ys, fit)[0] and same > 0.95
    noise = [rng.normal(size=x.shape) for x in xs]
    assert cross_validated_r2(xs, ys, fit, held_xs=noise)[0] < 0.0


@pytest.mark.skipif(not FestivalBackend().is_available(), reason="Festival not installed")
def test_festival_speaks_a_clip_at_the_persons_timing(tmp_path) -> None:
    """voiced_recordings: the clip's words in Festival's voice, as long as the person's
    phones, loud where he speaks and quiet in his lead-in."""
    import json

    from miketalk_lab.bench.other_voice import voiced_recordings

    person = (Phone("pau", 0.0, 0.6), Phone("b", 0.6, 0.66), Phone("l", 0.66, 0.72),
              Phone("uw", 0.72, 0.95), Phone("pau", 0.95, 1.3))  # fmt: skip
    words = [{"word": "blue", "clip": "c1", "start": 0.6, "end": 0.95, "phones": []}]
    (tmp_path / "words.json").write_text(json.dumps({"words": words}))
    (sound,) = voiced_recordings(tmp_path, ["c1"], [person], voice="kal", table=VisemeTable())
    x = sound.at_rate()
    assert abs(len(x) / RATE - 1.3) < 0.02
    lead, spoken = x[: int(0.5 * RATE)], x[int(0.62 * RATE) : int(0.93 * RATE)]
    assert np.abs(spoken).mean() > 10 * np.abs(lead).mean()


def test_mel_energies_in_blocks_are_the_whole_grids_bytes(monkeypatch) -> None:
    """Issue 50: a 12-minute recording's standardization grid (71,000 windows) was analysed at
    once, 1.5 GB of segments and spectra; now :data:`BLOCK` windows at a time, the same bytes
    whatever the block."""
    from miketalk.speech import acoustic

    rng = np.random.default_rng(3)
    samples = rng.normal(size=RATE * 90).astype(np.float32)
    times = np.arange(-0.05, 90.05, 0.01)  # past both ends: the zeros outside
    whole = acoustic.mel_energies(samples, times)
    assert whole.shape == (len(times), acoustic.BANDS) and len(times) > acoustic.BLOCK
    for block in (37, 10**6):  # short blocks; all at once
        monkeypatch.setattr(acoustic, "BLOCK", block)
        np.testing.assert_array_equal(acoustic.mel_energies(samples, times), whole)
