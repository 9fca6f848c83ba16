"""The voiced audio a recording's aligned words leave unexplained, and the warning of
``say --audio`` / ``cues --audio`` when a transcript says much less than the recording (the
text then a guide, the rest filled with the recognizer's words: test_guided_text)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_cli import shifted_model

from miketalk.media.audio import write_wav
from miketalk.media.decode import read_media_audio
from miketalk.speech.coverage import frame_levels, speech_coverage
from miketalk.speech.types import Phone

ROOT = Path(__file__).resolve().parents[2]
RATE = 16000
#: GRID s1 saying "bin blue at s three again" (six words)
CLIP = ROOT / "data/grid_s1/video/bbas3a.mpg"
WARNING = re.compile(
    r"(\d+)% of its ([\d.]+) s of voiced audio lies outside the aligned words "
    r"\(([\d.]+) s unexplained"
)


def bursts(n: int = 6) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """``n`` voiced syllables (0.25 s of a 150 Hz voice, 0.1 s apart) in faint noise, and
    clicks (10 ms) before and after them; the syllables' spans."""
    rng = np.random.default_rng(0)
    x = rng.normal(0, 30, int(RATE * (0.5 + 0.35 * n + 0.5)))
    spans = []
    for k in range(n):
        start = 0.5 + 0.35 * k
        t = np.arange(int(0.25 * RATE)) / RATE
        voice = sum(np.sin(2 * np.pi * 150 * h * t) / h for h in range(1, 6))
        i = int(start * RATE)
        x[i : i + len(t)] += 6000 * voice
        spans.append((start, start + 0.25))
    for at in (0.2, len(x) / RATE - 0.2):
        i = int(at * RATE)
        x[i : i + RATE // 100] += 20000
    return x.astype(np.int16), spans


def test_frame_levels_are_each_window_s_level_whatever_the_block() -> None:
    """The levels are computed a block of windows at a time (a long recording's overlapping
    windows are never all held at once): each is its window's mean-removed power, and the
    block size changes no value."""
    rng = np.random.default_rng(1)
    x = (rng.normal(0, 1, 5003) * np.linspace(1, 1000, 5003) + 500).astype(np.int16)
    frame, hop = 640, 160
    direct = [
        10 * np.log10(np.mean((w - w.mean()) ** 2) + 1e-12)
        for w in (x[k : k + frame].astype(np.float64) for k in range(0, len(x) - frame + 1, hop))
    ]
    levels = frame_levels(x, frame, hop)
    assert len(levels) == 1 + (len(x) - frame) // hop == len(direct)
    np.testing.assert_allclose(levels, direct, rtol=1e-12)
    for block in (1, 3, 7, len(levels)):
        np.testing.assert_array_equal(frame_levels(x, frame, hop, block=block), levels)
    assert levels[-1] > levels[0] + 15  # the louder end reads louder


def test_one_word_of_six_leaves_five_sixths_unexplained() -> None:
    samples, spans = bursts()
    everything = [Phone("aa", a, b) for a, b in spans]
    whole = speech_coverage(samples, RATE, everything)
    # a 40 ms frame that takes in the edge of a syllable is loud: each is ~30 ms longer
    assert whole.voiced_seconds == pytest.approx(6 * 0.25, abs=0.25)
    assert whole.unexplained_seconds == 0 and not whole.mismatch  # the clicks are not voiced
    one = speech_coverage(samples, RATE, [Phone("pau", 0, spans[0][0]), everything[0]])
    assert one.unexplained_share == pytest.approx(5 / 6, abs=0.05)
    assert one.mismatch
    # the longest run unexplained: one syllable (0.25 s, its loud frames ~30 ms longer)
    assert whole.longest_unexplained == 0 and 0.2 <= one.longest_unexplained <= 0.35
    silence = speech_coverage(np.zeros(RATE, np.int16), RATE, [Phone("pau", 0, 1)])
    assert silence.voiced_seconds == 0 and silence.unexplained_share == 0


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The six-word GRID sentence as a wav."""
    wav = tmp_path_factory.mktemp("rec") / "rec.wav"
    write_wav(wav, read_media_audio(CLIP, rate=RATE), RATE)
    return wav


def miketalk(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "miketalk.cli", *map(str, args)],
        cwd=cwd, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip


def test_say_audio_warns_when_the_text_is_one_word_of_six(recording: Path, tmp_path: Path) -> None:
    """One word of six: the text is a guide (miketalk.talk.guided), the speech it does not
    hold filled with the recognizer's words, in one warning; the video is still made."""
    model = shifted_model(tmp_path / "model", 64)
    proc = miketalk("say", "--audio", recording, "--text", "bin", "-o", "one.mp4",
                    "--model", model, cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr  # a warning: the video is still made
    (line,) = [ln for ln in proc.stderr.splitlines() if "WARNING" in ln]
    assert "the text is a guide here: 1 of its 1 words placed" in line and str(recording) in line
    assert "speech it does not hold filled with the words whisper-base@" in line
    assert not WARNING.search(proc.stderr)  # filled: the speech is no longer unexplained
    assert (tmp_path / "one.mp4").stat().st_size > 0
    full = miketalk("say", "--audio", recording, "--text", "Bin blue at S three again.",
                    "-o", "six.mp4", "--model", model, cwd=tmp_path)  # fmt: skip
    assert full.returncode == 0 and "WARNING" not in full.stderr, full.stderr


def test_cues_audio_warns_too(recording: Path, tmp_path: Path) -> None:
    proc = miketalk("cues", "--audio", recording, "--text", "bin", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "the text is a guide here: 1 of its 1 words placed" in proc.stderr, proc.stderr
    assert proc.stdout.startswith("0.00\t")  # the cues on stdout, the warning apart
