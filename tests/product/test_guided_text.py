"""A recording's approximate text as a guide (miketalk.talk.guided, miketalk.speech.align_guide):
a word the recording does not say is left out and named, speech the text does not hold is
filled with the recognizer's words, and a text mostly not said is refused in one line.

The recordings are Festival's (voice_kal_diphone), so what each says is known."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import wave
from pathlib import Path

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.speech import FestivalBackend
from miketalk.speech.align.phones import UnplacedWord, align
from miketalk.speech.align_guide import ROOM_PER_WORD, HeardSpan, merge, pairs
from miketalk.speech.coverage import speech_coverage
from miketalk.talk.guided import UNCOVERED_SECONDS

pytestmark = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival with voice_kal_diphone not installed"
)

#: What the recordings say after their lead-in.
SAID = "please put the red box by seven green boxes now"
#: Said before SAID in the recording with a lead-in; no text given holds it.
LEAD = "and so we moved on"


def _spans(words: str, start: float = 0.0, step: float = 0.3) -> list[HeardSpan]:
    return [
        HeardSpan(w, start + k * step, start + k * step + 0.25) for k, w in enumerate(words.split())
    ]


def test_the_text_and_the_heard_words_are_merged_by_the_rules() -> None:
    # a caption line cut longer than its clip at the start: its first words are out
    text = "continues and we are learning more we know that he traveled".split()
    heard = _spans("we know that he traveled to yemen a country")
    guided = merge(text, heard, duration=2.8)
    assert guided.words == tuple("we know that he traveled to yemen a country".split())
    assert [i for _, i in zip(guided.words, guided.text_index, strict=True)][:5] == [6, 7, 8, 9, 10]
    assert guided.filled == ("to", "yemen", "a", "country")
    assert [w for _, w in guided.left_out] == "continues and we are learning more".split()
    # an unscripted lead-in is filled; a word heard a little wrong keeps the text's spelling
    guided = merge(
        "about the very real challenges".split(),
        _spans("as they were about the ferry real challenges"),
        2.5,
    )
    assert guided.words == tuple("as they were about the very real challenges".split())
    assert guided.filled == ("as", "they", "were") and not guided.left_out
    # the same speech heard wrong as one word: the text's words stay ("bimble" for "bin blue at")
    guided = merge("bin blue at f two now".split(), _spans("bimble f two now"), 3.0)
    assert guided.words == tuple("bin blue at f two now".split()) and not guided.filled
    # a short word the recognizer missed, between two it heard: kept for the aligner to place
    assert merge("set red at u now".split(), _spans("set red u now"), 2.0).words == tuple(
        "set red at u now".split()
    )
    # a text word at the end beyond the heard speech: out only when there is no room for it
    heard = _spans("we talked about their")  # ends at 1.15 s
    assert merge(
        "we talked about their struggles".split(), heard, 1.15 + ROOM_PER_WORD / 2
    ).left_out == ((4, "struggles"),)
    assert (
        "struggles"
        in merge("we talked about their struggles".split(), heard, 1.15 + 2 * ROOM_PER_WORD).words
    )
    # unlike words in the same place are not paired: the heard ones are what was said there
    steps = pairs("the answers to".split(), "plenty of ideas".split())
    assert all(i is None or j is None for i, j in steps)


def _write_wav(path: Path, samples: np.ndarray, rate: int) -> None:
    with wave.open(str(path), "wb") as f:
        f.setnchannels(1)
        f.setsampwidth(2)
        f.setframerate(rate)
        f.writeframes(np.asarray(samples, np.int16).tobytes())


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, float]]:
    """Festival saying SAID (``said``), and LEAD then, after 0.2 s, SAID (``lead``): each wav,
    and where its first word "please" starts (s)."""
    festival, tmp = FestivalBackend(), tmp_path_factory.mktemp("guided")
    said, lead = festival.synthesize(SAID), festival.synthesize(LEAD)
    assert said.rate == lead.rate == 16000
    please = next(p.start for p in said.phones if p.name != "pau")
    _write_wav(tmp / "said.wav", said.samples, said.rate)
    pause = np.zeros(round(0.2 * said.rate), np.int16)
    _write_wav(tmp / "lead.wav", np.concatenate([lead.samples, pause, said.samples]), said.rate)
    offset = (len(lead.samples) + len(pause)) / said.rate
    return {"said": (tmp / "said.wav", please), "lead": (tmp / "lead.wav", offset + please)}


def _read(path: Path) -> np.ndarray:
    with wave.open(str(path)) as f:
        return np.frombuffer(f.readframes(f.getnframes()), dtype="<i2")


def _starts(phones, names: str, at: float, within: float = 0.1) -> bool:
    """Whether the phones ``names`` follow one another from within ``within`` s of ``at``."""
    seq = names.split()
    return any(
        [p.name for p in phones[k : k + len(seq)]] == seq and abs(phones[k].start - at) <= within
        for k in range(len(phones))
    )


def test_a_right_text_is_aligned_as_before(recordings, caplog) -> None:
    from miketalk.talk.recorded import align_recording

    path, _ = recordings["said"]
    with caplog.at_level(logging.WARNING):
        aligned = align_recording(path, text=SAID)
    assert not caplog.records and aligned.filled_by is None and not aligned.left_out
    assert aligned.words == tuple(SAID.split())
    assert aligned.phones == align(_read(path), 16000, SAID.split()).phones


def test_a_word_the_recording_does_not_say_is_left_out_and_named(
    recordings, caplog, monkeypatch
) -> None:
    from miketalk.speech import align_guide
    from miketalk.talk.recorded import align_recording

    path, _ = recordings["said"]
    text = f"{SAID} tomorrow at dawn"
    with pytest.raises(UnplacedWord):  # the aligner alone refuses it (as every dub did)
        align(_read(path), 16000, text.split())
    with caplog.at_level(logging.WARNING):
        aligned = align_recording(path, text=text)
    assert aligned.words == tuple(SAID.split())
    assert aligned.left_out == ("tomorrow", "at", "dawn")
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "10 of its 13 words placed" in warnings[0]
    assert "'tomorrow at dawn' (3 words)" in warnings[0]
    # without the recognizer the aligner alone leaves them out
    caplog.clear()

    def not_installed(*_):
        raise MiketalkError("speech recognition is not installed")

    monkeypatch.setattr(align_guide, "heard_spans", not_installed)
    with caplog.at_level(logging.WARNING):
        alone = align_recording(path, text=text)
    assert alone.left_out == ("tomorrow", "at", "dawn") and alone.filled_by is None
    assert "not filled (speech recognition is not installed)" in caplog.text


def test_an_unscripted_lead_in_is_filled_with_the_heard_words(
    recordings, caplog, monkeypatch
) -> None:
    from miketalk.speech import align_guide
    from miketalk.talk.recorded import align_recording

    path, please = recordings["lead"]
    samples = _read(path)
    plain = align(samples, 16000, SAID.split())  # the text alone: its words over the lead-in
    assert speech_coverage(samples, 16000, plain.phones).longest_unexplained >= UNCOVERED_SECONDS
    assert not _starts(plain.phones, "p l", please)
    with caplog.at_level(logging.WARNING):
        aligned = align_recording(path, text=SAID)
    assert aligned.filled_by is not None and aligned.filled_by.startswith("whisper-base@")
    assert aligned.words[-len(SAID.split()) :] == tuple(SAID.split()) and not aligned.left_out
    filled = aligned.words[: len(aligned.words) - len(SAID.split())]
    assert 2 <= len(filled) <= 8  # what Whisper heard of "and so we moved on"
    assert _starts(aligned.phones, "p l", please)  # "please" where it is said
    assert next(p for p in aligned.phones if p.name != "pau").start < please - 1.0
    assert "speech it does not hold filled with the words whisper-base@" in caplog.text
    # without the recognizer: the text's own alignment, and a warning that nothing filled it
    caplog.clear()
    monkeypatch.setattr(
        align_guide, "heard_spans", lambda *_: (_ for _ in ()).throw(MiketalkError("off"))
    )
    with caplog.at_level(logging.WARNING):
        alone = align_recording(path, text=SAID)
    assert alone.phones == plain.phones and alone.filled_by is None
    assert "lie outside the text's words, not filled (off)" in caplog.text


def _cues(audio: Path, text: str, out: Path) -> subprocess.CompletedProcess:
    """``miketalk cues --audio AUDIO --text TEXT -o OUT``."""
    return subprocess.run(
        [sys.executable, "-m", "miketalk.cli", "cues", "--audio", str(audio), "--text", text,
         "-o", str(out)],
        capture_output=True, text=True, check=False, timeout=300,
    )  # fmt: skip


def test_a_text_mostly_not_said_is_refused_in_one_line(recordings, tmp_path: Path) -> None:
    path, _ = recordings["said"]
    text = "please put the weather in the mountains was cold and grey all through the long winter"
    proc = _cues(path, text, tmp_path / "c.json")
    assert proc.returncode == 2, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "of the text's 16 words could be placed" in lines[0], proc.stderr
    assert "is the text this recording's?" in lines[0] and not (tmp_path / "c.json").exists()
    # the lead-in recording with its text: accepted, in one warning that names the filled words
    lead, _ = recordings["lead"]
    proc = _cues(lead, SAID, tmp_path / "lead.json")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("the text is a guide here") == 1
    assert "filled with the words whisper-base@" in proc.stderr
    assert json.loads((tmp_path / "lead.json").read_text())["mouthCues"]
