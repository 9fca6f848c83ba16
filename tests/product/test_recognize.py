"""The speech recognizer (miketalk.speech.recognize): its weights checked, its words made
alignable, its rule refusing speech that is not English and noise, and recordings spoken
without their text."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio
from miketalk.speech.recognize import Heard, HeardWord, get_recognizer, spoken_words
from miketalk.speech.recognize.judge import (
    CONFIDENCE_LIMIT,
    ENGLISH_LIMIT,
    MIN_SPEECH_SECONDS,
    judge,
)
from miketalk.speech.recognize.whisper import INSTALL_HINT, WHISPER_BASE, Weights

ROOT = Path(__file__).resolve().parents[2]
CLIPS = ROOT / "data" / "grid_s1" / "video"
HERE = Path(__file__).resolve().parent / "data"
RATE = 16000


def test_a_recognizers_writing_becomes_words_to_align() -> None:
    assert spoken_words("Lay blue at K2, please.") == ["lay", "blue", "at", "k", "two", "please"]
    assert spoken_words("Place red by X-ray soon.") == ["place", "red", "by", "x", "ray", "soon"]
    assert spoken_words("In 2009, 3.5% of $1,200") == [
        "in", "two", "thousand", "nine", "three", "point", "five", "percent", "of", "one",
        "thousand", "two", "hundred", "dollars",
    ]  # fmt: skip
    assert spoken_words("the 1990s, the 21st and 2nd, 1905") == [
        "the", "nineteen", "nineties", "the", "twenty", "first", "and", "second", "nineteen",
        "oh", "five",
    ]  # fmt: skip
    assert spoken_words("We're here.") == ["we're", "here"]


def test_weights_with_another_checksum_are_refused_unloaded() -> None:
    name, parts, sha256 = WHISPER_BASE.files[1]  # config.json: small to read
    forged = Weights("whisper-base", ((name, parts, "0" * 64),))
    with pytest.raises(MiketalkError, match=r"has sha256 [0-9a-f]{64}, not 0{64}: refusing"):
        forged.read()
    assert Weights("whisper-base", ((name, parts, sha256),)).read()[name]
    missing = Weights("whisper-base", (("model.bin", (("no_such_package_x", "m"),), sha256),))
    with pytest.raises(MiketalkError, match=re.escape(INSTALL_HINT)):
        missing.read()


def _heard(english: float, probabilities: list[float], speech: float = 2.0) -> Heard:
    words = tuple(HeardWord(f"w{i}", i, i + 0.5, p) for i, p in enumerate(probabilities))
    return Heard(words, "en" if english > 0.5 else "de", english, "test", speech)


def test_the_rule_refuses_another_language_and_noise_in_one_line() -> None:
    judge(_heard(ENGLISH_LIMIT + 0.01, [CONFIDENCE_LIMIT + 0.01] * 3), "a.wav")  # passes
    with pytest.raises(MiketalkError, match=r"^a.wav: no speech heard \(0.2 s of it"):
        judge(_heard(0.9, [0.99] * 3, speech=MIN_SPEECH_SECONDS - 0.1), "a.wav")
    with pytest.raises(MiketalkError, match=r"^a.wav: the speech does not sound English"):
        judge(_heard(ENGLISH_LIMIT - 0.01, [0.99] * 3), "a.wav")
    for probabilities in ([CONFIDENCE_LIMIT - 0.01] * 3, []):
        with pytest.raises(MiketalkError, match=r"^a.wav: no speech recognized with confidence"):
            judge(_heard(0.9, probabilities), "a.wav")
    with pytest.raises(MiketalkError, match=r"or not English \(it sounds most like 'de'"):
        judge(_heard(0.3, [CONFIDENCE_LIMIT - 0.01] * 3), "a.wav")


@pytest.fixture(scope="module")
def whisper():
    return get_recognizer("whisper-base")


def test_whisper_hears_an_s1_clip_and_the_same_twice(whisper) -> None:
    samples = read_media_audio(CLIPS / "lbaq6p.mpg", rate=RATE)  # "lay blue at q six please"
    heard = whisper.hear(samples, RATE)
    words = [w for word in heard.words for w in spoken_words(word.text)]
    assert words == ["lay", "blue", "at", "q", "six", "please"]
    assert heard.language == "en" and heard.recognizer.startswith("whisper-base@905e5bf8")
    assert all(0 <= w.start < w.end <= len(samples) / RATE + 0.05 for w in heard.words)
    assert whisper.hear(samples, RATE) == heard  # deterministic: temperature 0 only


def test_what_was_heard_is_kept_for_the_same_recording(whisper, tmp_path, monkeypatch) -> None:
    """A second hearing of the same samples is read from the cache (issue 53's second dub),
    the same :class:`Heard`; other samples are heard; a stand-in recognizer is never kept."""
    from miketalk.speech.recognize import kept

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    samples = read_media_audio(CLIPS / "lbaq6p.mpg", rate=RATE)
    heard = kept.kept_hear(whisper, samples, RATE)
    assert heard == whisper.hear(samples, RATE)
    calls: list[int] = []
    real = type(whisper).hear
    monkeypatch.setattr(type(whisper), "hear", lambda s, a, r: calls.append(1) or real(s, a, r))
    assert kept.heard_key(whisper, samples, RATE) is None  # this hear is not the package's
    monkeypatch.undo()
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))

    class Unloaded:
        def __getattr__(self, name):
            raise AssertionError("heard again")

    monkeypatch.setattr(whisper, "_model", Unloaded())  # the package's hear, no model
    with pytest.raises(AssertionError, match="heard again"):
        whisper.hear(samples, RATE)
    assert kept.kept_hear(whisper, samples, RATE) == heard  # read, not heard
    other = samples.copy()
    other[len(other) // 2] += 1  # one sample other: heard again
    key = kept.heard_key(whisper, other, RATE)
    assert key is not None and key != kept.heard_key(whisper, samples, RATE)
    from miketalk.media.user_cache import read_record

    assert read_record(kept.KIND, *key) is None

    class StandIn(kept.Recognizer):
        name = "stand-in"

        def hear(self, samples, rate):
            calls.append(1)
            return heard

    for _ in range(2):
        assert kept.kept_hear(StandIn(), samples, RATE) == heard
    assert len(calls) == 2


@pytest.mark.parametrize("language", ["de", "es"])
def test_speech_in_another_language_is_one_line(whisper, language: str) -> None:
    samples = read_media_audio(HERE / f"espeak_{language}.flac", rate=RATE)
    heard = whisper.hear(samples, RATE)
    assert heard.language == language
    with pytest.raises(MiketalkError, match=f"does not sound English|not English.*{language!r}"):
        judge(heard, "x")


@pytest.mark.parametrize("kind", ["white", "hum"])
def test_noise_is_one_line(whisper, kind: str) -> None:
    """Whisper writes words over a hum ("I'm sorry, I'm sorry, ..." with confidence 0.96):
    the voice detector finds no speech in it."""
    rng = np.random.default_rng(0)
    n = 3 * RATE
    noise = (
        rng.normal(0, 3000, n)
        if kind == "white"
        else 2000 * np.sin(2 * np.pi * 50 * np.arange(n) / RATE) + rng.normal(0, 200, n)
    )
    with pytest.raises(MiketalkError, match=r"^noise: no speech heard"):
        judge(whisper.hear(noise.astype(np.int16), RATE), "noise")


def test_a_recording_without_its_text_is_recognized_then_aligned() -> None:
    from miketalk.talk.recorded import align_recording

    aligned = align_recording(CLIPS / "lbaq6p.mpg")
    assert aligned.words == ("lay", "blue", "at", "q", "six", "please")
    assert aligned.heard is not None and aligned.heard.recognizer.startswith("whisper-base")
    given = align_recording(CLIPS / "lbaq6p.mpg", text="lay blue at q six please")
    assert given.heard is None
    assert [p.name for p in aligned.phones] == [p.name for p in given.phones]


def test_a_video_without_its_script_is_built_from_its_recognized_words(
    s1_joined, tmp_path: Path
) -> None:
    """The joined s1 video with no transcript: its cues are the words heard with confidence,
    the others left out and named in segments.json, which says who heard them."""
    import json

    from miketalk.corpus.heard_script import WORD_CONFIDENCE
    from miketalk.corpus.one_video import segment_video

    doc = segment_video(s1_joined.video, tmp_path / "segments.json", heldout_seconds=6)
    assert doc["words_from"].startswith("whisper-base@905e5bf8")
    assert json.loads((tmp_path / "segments.json").read_text())["words_from"] == doc["words_from"]
    assert all(w["probability"] < WORD_CONFIDENCE for w in doc["not_confident"])
    # GRID's sentences are hard for Whisper: 8 of the 22 words heard without confidence
    assert doc["not_confident"]
    said = " ".join(u["text"] for u in doc["utterances"]).split()
    assert doc["words"] == len(said) + len(doc["unaligned"])  # each placed, or named
    assert any(u["split"] == "train" for u in doc["utterances"])
    assert any(u["split"] == "test" for u in doc["utterances"])


def test_the_edit_distance_is_levenshteins() -> None:
    from miketalk.speech.recognize.agree import disagreement, edit_distance

    assert edit_distance("kitten", "sitting") == 3
    assert edit_distance("flaw", "lawn") == 2
    assert edit_distance("", "abc") == 3 and edit_distance("abc", "") == 3
    assert edit_distance(["bin", "blue"], ["bin", "blue"]) == 0
    # letters, not words: "bimble" is 2 letters of "binblue" away, not 2 words of 2
    assert disagreement(["bin", "blue"], ["bimble"]) == pytest.approx(2 / 7)
    assert disagreement(["set", "red"], ["set", "red"]) == 0.0


def test_a_text_the_recognizer_disagrees_with_is_warned_about(caplog) -> None:
    from miketalk.speech.recognize.agree import DISAGREEMENT_LIMIT, warn_disagreement

    heard = "bimble f two now".split()
    with caplog.at_level("WARNING"):
        share = warn_disagreement("a.wav", "bin blue at f two now".split(), heard)
    assert share <= DISAGREEMENT_LIMIT and not caplog.records
    with caplog.at_level("WARNING"):
        share = warn_disagreement("a.wav", "place red by x eight soon".split(), heard)
    assert share > DISAGREEMENT_LIMIT
    assert len(caplog.records) == 1 and "disagree" in caplog.records[0].getMessage()


def test_phones_recognized_take_the_heard_words_over_the_text(caplog) -> None:
    """``--phones recognized`` with a text: the words are the recognizer's, and a text of
    another clip is warned about; ``aligned`` (the default) keeps the text."""
    from miketalk.errors import SettingError
    from miketalk.talk.recorded import align_recording
    from miketalk.talk.speech import Recorded

    clip, other = CLIPS / "lbaq6p.mpg", "place red by x eight soon"
    with caplog.at_level("WARNING"):
        heard = align_recording(clip, text=other, phones="recognized")
    assert heard.words == ("lay", "blue", "at", "q", "six", "please")
    assert heard.heard is not None
    assert any("disagree" in r.getMessage() for r in caplog.records)
    with pytest.raises(SettingError, match=r"phones.*timings"):
        Recorded(clip, timings="x.align", phones="recognized")
    with pytest.raises(SettingError, match=r"phones"):
        Recorded(clip, phones="guessed")
