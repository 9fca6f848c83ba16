"""Forced alignment (pocketsphinx, Festival phones), word timings, and media audio.

The speech is Festival's own (voice_kal_diphone): it says a known sentence and
tells where each word is, and the aligner has to find the same words there.
"""

from __future__ import annotations

import csv
import os
import re
import statistics
import subprocess
import wave
from importlib import resources
from itertools import pairwise
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio
from miketalk.speech.align import (
    align,
    align_phones,
    arpabet_table,
    decoder,
    festival_pronunciations,
)
from miketalk.speech.align import phones as align_phones_module
from miketalk.speech.word_timings import WordTiming, read_word_timings

#: "zorgle" is in no dictionary: Festival's letter-to-sound rules pronounce it.
SENTENCE = "please put the zorgle by seven green boxes now"

#: Synthesizes $TEST_TEXT; writes the wave and each word's start and end (s).
_SYNTH_SCM = """
(voice_kal_diphone)
(set! utt (eval (list 'Utterance 'Text (string-append "" (getenv "TEST_TEXT")))))
(utt.synth utt)
(utt.save.wave utt (getenv "TEST_WAV") 'riff)
(set! fd (fopen (getenv "TEST_WORDS") "w"))
(mapcar
 (lambda (w)
   (format fd "%s %f %f\\n" (item.name w)
           (item.feat w "R:SylStructure.daughter1.daughter1.segment_start")
           (item.feat w "R:SylStructure.daughtern.daughtern.segment_end")))
 (utt.relation.items utt 'Word))
(fclose fd)
"""


@pytest.fixture(scope="module")
def spoken(tmp_path_factory) -> tuple[np.ndarray, int, list[WordTiming]]:
    """Festival saying SENTENCE: int16 samples, rate, and Festival's word timings."""
    tmp = tmp_path_factory.mktemp("festival")
    scheme, wav, words = tmp / "synth.scm", tmp / "speech.wav", tmp / "words.txt"
    scheme.write_text(_SYNTH_SCM)
    env = {
        "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
        "HOME": str(tmp),
        "TEST_TEXT": SENTENCE,
        "TEST_WAV": str(wav),
        "TEST_WORDS": str(words),
    }
    subprocess.run(
        ["festival", "--heap", "1000000", "-b", str(scheme)],
        env=env, cwd=tmp, check=True, capture_output=True, timeout=60,
    )  # fmt: skip
    with wave.open(str(wav)) as f:
        rate = f.getframerate()
        samples = np.frombuffer(f.readframes(f.getnframes()), dtype="<i2").astype(np.int16)
    timings = []
    for line in words.read_text().splitlines():
        word, start, end = line.split()
        timings.append(WordTiming(word, float(start), float(end)))
    assert " ".join(t.word for t in timings) == SENTENCE
    return samples, rate, timings


def _radio_phones() -> set[str]:
    """The radio phones of the project's phone table (data/phones.tsv)."""
    text = resources.files("miketalk.data").joinpath("phones.tsv").read_text("utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("# ")]
    return {row["phone"] for row in csv.DictReader(lines, delimiter="\t")}


def _check_contiguous(phones, duration: float) -> None:
    radio = _radio_phones()
    assert phones[0].start == 0.0
    assert phones[-1].end == pytest.approx(duration, abs=1e-9)
    for a, b in pairwise(phones):
        assert a.end == pytest.approx(b.start, abs=1e-9)
        assert not (a.name == b.name == "pau")
    for p in phones:
        assert p.end > p.start
        assert p.name in radio


# ---------------------------------------------------------------------------
# alignment of Festival's speech
# ---------------------------------------------------------------------------


def test_word_boundaries_match_festivals(spoken):
    samples, rate, festival_words = spoken
    result = align(samples, rate, SENTENCE.split())
    assert [w.word for w in result.words] == SENTENCE.split()
    errors = []
    for ours, theirs in zip(result.words, festival_words, strict=True):
        errors += [abs(ours.start - theirs.start), abs(ours.end - theirs.end)]
    assert statistics.median(errors) <= 0.025
    assert max(errors) <= 0.07
    _check_contiguous(result.phones, len(samples) / rate)
    assert align_phones(samples, rate, SENTENCE.split()) == list(result.phones)


def _cmu_dictionary() -> dict[str, list[str]]:
    import pocketsphinx

    path = Path(pocketsphinx.get_model_path(), "en-us", "cmudict-en-us.dict")
    entries = {}
    with path.open() as f:
        for line in f:
            word, *phones = line.split()
            entries[word] = phones
    return entries


def test_missing_word_gets_festivals_pronunciation(spoken):
    samples, rate, _ = spoken
    assert "zorgle" not in _cmu_dictionary()
    expected = festival_pronunciations(["Zorgle"])["zorgle"]
    assert expected == ["z", "ao", "r", "g", "ax", "l"]
    result = align(samples, rate, SENTENCE.split())
    zorgle = result.words[3]
    inside = [p.name for p in result.phones if zorgle.start <= p.start < zorgle.end]
    assert inside == expected


def test_pronounce_is_asked_for_missing_words_only(spoken):
    samples, rate, _ = spoken
    asked = []

    def pronounce(word: str) -> list[str]:
        asked.append(word)
        return ["z", "ao", "r", "g", "el"]  # el: a syllabic l, two ARPAbet phones

    result = align(samples, rate, SENTENCE.upper().split(), pronounce=pronounce)
    assert asked == ["zorgle"]
    zorgle = result.words[3]
    inside = [p.name for p in result.phones if zorgle.start <= p.start < zorgle.end]
    assert inside == ["z", "ao", "r", "g", "el"]
    # another pronunciation of a word added before: the aligner starts afresh with it
    other = align(samples, rate, SENTENCE.split(), pronounce=lambda w: "z ow r g ax l".split())
    zorgle = other.words[3]
    inside = [p.name for p in other.phones if zorgle.start <= p.start < zorgle.end]
    assert inside == ["z", "ow", "r", "g", "ax", "l"]


def test_a_stop_after_silence_keeps_a_closure_of_max_closure():
    # the aligner let "place"'s P swallow the 0.62 s of silence before it (a GRID clip)
    aligned = [
        ("<s>", [("SIL", 0, 1, 1)]),
        ("place", [("P", 1, 62, 56), ("L", 62, 65, 63), ("EY", 65, 71, 66), ("S", 71, 78, 74)]),
        ("blue", [("B", 78, 88, 83), ("L", 88, 91, 89), ("UW", 91, 100, 93)]),
        ("<sil>", [("SIL", 100, 110, 104)]),
        ("by", [("B", 110, 130, 125), ("AY", 130, 140, 133)]),
    ]
    spans, phones = align_phones_module._read_alignment(aligned, 100, {})
    cap = align_phones_module.MAX_CLOSURE
    assert spans[0][0] == pytest.approx(0.56 - cap)
    assert phones[1] == ("p", pytest.approx(0.56 - cap), 0.62)
    assert spans[1][0] == 0.78  # after a word: untouched
    assert spans[2][0] == pytest.approx(1.25 - cap)  # after a pause
    assert [p[0] for p in phones] == "pau p l ey s b l uw pau b ay".split()


def test_phones_stay_inside_given_word_timings(spoken):
    samples, rate, festival_words = spoken
    duration = len(samples) / rate
    # move every word 30 ms later and shorten it by 20 ms: the aligner's spans differ
    given = [WordTiming(w.word, w.start + 0.03, w.end + 0.01) for w in festival_words]
    phones = align_phones(samples, rate, SENTENCE.split(), word_timings=given)
    _check_contiguous(phones, duration)
    for p in phones:
        if p.name == "pau":
            continue
        assert any(w.start - 1e-9 <= p.start and p.end <= w.end + 1e-9 for w in given), p
    for w in given:  # each word is covered by its own phones, edge to edge
        inside = [p for p in phones if w.start - 1e-9 <= p.start and p.end <= w.end + 1e-9]
        assert inside[0].start == pytest.approx(w.start)
        assert inside[-1].end == pytest.approx(w.end)
        assert "pau" not in [p.name for p in inside]
    result = align(samples, rate, SENTENCE.split(), word_timings=given)
    assert [(w.start, w.end) for w in result.words] == [(w.start, w.end) for w in given]


def test_float_audio_at_another_rate(spoken):
    samples, rate, _ = spoken
    resampled = decoder._resample(samples / 32768.0, rate, 22050)
    ours = align(resampled, 22050, SENTENCE.split())
    reference = align(samples, rate, SENTENCE.split())
    for a, b in zip(ours.words, reference.words, strict=True):
        assert abs(a.start - b.start) <= 0.021
        assert abs(a.end - b.end) <= 0.021
    assert ours.phones[-1].end == pytest.approx(len(resampled) / 22050)


def test_resample_keeps_a_tone():
    rate, target = 44100, 16000
    t = np.arange(rate) / rate
    tone = np.sin(2 * np.pi * 440.0 * t)
    out = decoder._resample(tone, rate, target)
    assert len(out) == target
    expected = np.sin(2 * np.pi * 440.0 * np.arange(target) / target)
    middle = slice(100, -100)  # away from the zero padding at the ends
    assert np.max(np.abs(out[middle] - expected[middle])) < 2e-3
    # a tone above the new Nyquist frequency is filtered out, not folded back
    high = decoder._resample(np.sin(2 * np.pi * 10000.0 * t), rate, target)
    assert np.max(np.abs(high[middle])) < 0.01


def test_a_word_that_cannot_be_placed_is_named(spoken):
    samples, rate, _ = spoken
    words = SENTENCE.split() + ["again"] * 20
    with pytest.raises(MiketalkError, match=r"cannot align the word 'again'"):
        align_phones(samples, rate, words)
    with pytest.raises(MiketalkError, match="cannot align the word"):
        align_phones(samples[: rate // 5], rate, SENTENCE.split())


def test_bad_input_is_refused(spoken):
    samples, rate, festival_words = spoken
    with pytest.raises(MiketalkError, match="word timings given for"):
        align_phones(samples, rate, ["please"], word_timings=festival_words)
    swapped = [WordTiming("now", 0.1, 0.2), *festival_words[1:]]
    with pytest.raises(MiketalkError, match="given where 'please' is said"):
        align_phones(samples, rate, SENTENCE.split(), word_timings=swapped)
    with pytest.raises(MiketalkError, match="cannot pronounce the word"):
        align_phones(samples, rate, ["please", "(system"])
    with pytest.raises(MiketalkError, match="rate"):
        align_phones(samples, 0, ["please"])
    with pytest.raises(MiketalkError, match="audio"):
        align_phones(np.zeros(0, np.int16), rate, ["please"])
    silent = align_phones(samples, rate, [])
    assert [(p.name, p.start) for p in silent] == [("pau", 0.0)]


# ---------------------------------------------------------------------------
# the phone table and Festival's lexicon
# ---------------------------------------------------------------------------


def test_table_covers_every_cmu_phone_and_every_radio_phone():
    table = arpabet_table()
    cmu = {phone for phones in _cmu_dictionary().values() for phone in phones}
    assert len(cmu) == 39
    assert cmu | {"SIL"} <= set(table.to_festival)
    radio = _radio_phones()
    assert len(radio) == 50
    assert set(table.from_festival) == radio
    assert set(table.to_festival.values()) <= radio
    for festival, arpabet in table.from_festival.items():
        assert set(arpabet) <= cmu | {"SIL"}, festival
    for arpabet, festival in table.to_festival.items():  # the round trip
        if arpabet in cmu:
            assert table.from_festival[festival] == (arpabet,)


def test_festival_pronunciations():
    found = festival_pronunciations(["Hello", "button", "hello", "don't"])
    assert found == {
        "hello": ["hh", "ax", "l", "ow"],
        "button": ["b", "ah", "t", "ax", "n"],
        "don't": ["d", "ow", "n", "t"],
    }
    assert festival_pronunciations([]) == {}


def test_festival_never_sees_code(tmp_path):
    marker = tmp_path / "pwned"
    for word in [f'a") (system "touch {marker}") ("', "a;b", "a b", ""]:
        with pytest.raises(MiketalkError, match="cannot pronounce the word"):
            festival_pronunciations([word])
    assert not marker.exists()
    with pytest.raises(MiketalkError, match="Festival not found"):
        festival_pronunciations(["hello"], executable=str(tmp_path / "no-festival"))


# ---------------------------------------------------------------------------
# word timings
# ---------------------------------------------------------------------------


def test_read_grid_align(tmp_path):
    path = tmp_path / "bbaf2n.align"
    path.write_text(
        "0 23750 sil\n23750 29500 bin\n29500 34000 blue\n34000 35000 sp\n"
        "35000 41000 at\n41000 74500 sil\n"
    )
    assert read_word_timings(path) == [
        WordTiming("bin", 0.95, 1.18),
        WordTiming("blue", 1.18, 1.36),
        WordTiming("at", 1.4, 1.64),
    ]


@pytest.mark.parametrize(
    "text, message",
    [
        ("0 100\n", "line 1"),
        ("0 1x0 bin\n", "line 1"),
        ("0 100 bin\n100 50 blue\n", "bad times"),
        ("0 100 bin\n50 150 blue\n", "starts before"),
    ],
)
def test_bad_align_files_are_named(tmp_path, text, message):
    path = tmp_path / "bad.align"
    path.write_text(text)
    with pytest.raises(MiketalkError, match=message) as err:
        read_word_timings(path)
    assert str(path) in str(err.value)
    with pytest.raises(MiketalkError, match=re.escape("missing.align")):
        read_word_timings(tmp_path / "missing.align")


def _textgrid(tiers: list[tuple[str, list[tuple[float, float, str]]]]) -> str:
    lines = [
        'File type = "ooTextFile"', 'Object class = "TextGrid"', "",
        "xmin = 0", "xmax = 2", "tiers? <exists>", f"size = {len(tiers)}", "item []:",
    ]  # fmt: skip
    for i, (name, intervals) in enumerate(tiers, start=1):
        lines += [
            f"    item [{i}]:", '        class = "IntervalTier"', f'        name = "{name}"',
            "        xmin = 0", "        xmax = 2", f"        intervals: size = {len(intervals)}",
        ]  # fmt: skip
        for j, (start, end, label) in enumerate(intervals, start=1):
            lines += [
                f"        intervals [{j}]:", f"            xmin = {start}",
                f"            xmax = {end}", f'            text = "{label}"',
            ]  # fmt: skip
    return "\n".join(lines) + "\n"


def test_read_textgrid(tmp_path):
    phones = ("phones", [(0, 0.5, ""), (0.5, 0.7, "HH"), (0.7, 2, "")])
    words = ("Words", [(0, 0.5, ""), (0.5, 1.1, "hello"), (1.1, 1.2, "sp"), (1.2, 2, "world")])
    path = tmp_path / "a.TextGrid"
    path.write_text(_textgrid([phones, words]))
    assert read_word_timings(path) == [
        WordTiming("hello", 0.5, 1.1),
        WordTiming("world", 1.2, 2.0),
    ]
    other = tmp_path / "b.textgrid"  # no "words" tier: the first interval tier
    other.write_text(_textgrid([("ortho", [(0, 1, "hi"), (1, 2, "")])]))
    assert read_word_timings(other) == [WordTiming("hi", 0.0, 1.0)]


def test_bad_textgrid_is_named(tmp_path):
    path = tmp_path / "bad.TextGrid"
    path.write_text("this is not a TextGrid\n")
    with pytest.raises(MiketalkError, match=re.escape("bad.TextGrid")):
        read_word_timings(path)
    with pytest.raises(MiketalkError, match=re.escape("gone.TextGrid")):
        read_word_timings(tmp_path / "gone.TextGrid")


# ---------------------------------------------------------------------------
# media audio
# ---------------------------------------------------------------------------


def test_read_media_audio(tmp_path):
    rate = 44100
    t = np.arange(rate // 2) / rate
    left = (8000 * np.sin(2 * np.pi * 300 * t)).astype(np.int16)
    path = tmp_path / "tone.wav"
    with wave.open(str(path), "wb") as f:
        f.setnchannels(2)
        f.setsampwidth(2)
        f.setframerate(rate)
        f.writeframes(np.stack([left, left], axis=1).tobytes())
    samples = read_media_audio(path)
    assert samples.dtype == np.int16
    assert abs(len(samples) - 8000) <= 32
    assert 7000 < np.abs(samples).max() < 8500


def test_media_without_audio_is_named(tmp_path):
    path = tmp_path / "silent film.mpg"
    subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(), "-nostdin", "-loglevel", "error",
            "-f", "lavfi", "-i", "testsrc=size=64x64:rate=25", "-t", "0.2",
            "-c:v", "mpeg1video", str(path),
        ],
        check=True, capture_output=True, timeout=60,
    )  # fmt: skip
    with pytest.raises(MiketalkError, match=re.escape("silent film.mpg has no audio stream")):
        read_media_audio(path)
    with pytest.raises(MiketalkError, match=re.escape("nothing.mpg")):
        read_media_audio(tmp_path / "nothing.mpg")
