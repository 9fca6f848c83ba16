"""Festival front-end: timing, re-synthesis, injection safety, bad input."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.speech import FestivalBackend, Utterance, normalize_text, split_chunks

pytestmark = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival with voice_kal_diphone not installed"
)


@pytest.fixture(scope="module")
def festival() -> FestivalBackend:
    return FestivalBackend()


@pytest.fixture(scope="module")
def hello(festival: FestivalBackend) -> Utterance:
    return festival.synthesize("Hello world")


def test_hello_world_phones_and_wav_end_together(hello: Utterance) -> None:
    assert [p.name for p in hello.phones] == "pau hh ax l ow w er l d pau".split()
    assert hello.rate == 16000
    assert len(hello.samples) == round(hello.phones[-1].end * hello.rate)
    assert hello.phones[0].start == 0.0
    for a, b in pairwise(hello.phones):
        assert a.end == b.start and b.end > b.start


def test_resynthesis_lengthens_one_phone_and_shifts_every_later_boundary(
    festival: FestivalBackend, hello: Utterance
) -> None:
    k = 4  # "ow"
    durations = hello.durations()
    durations[k] += 0.040
    longer = festival.resynthesize(hello, durations)
    rate = hello.rate
    shift = [
        round((b.end - a.end) * rate) for a, b in zip(hello.phones, longer.phones, strict=True)
    ]
    assert all(s == 0 for s in shift[:k])
    assert all(abs(s - 0.040 * rate) <= 1 for s in shift[k:])
    assert abs(len(longer.samples) - len(hello.samples) - 0.040 * rate) <= 1

    # The sound after the lengthened phone is the same sound, about 40 ms later:
    # the best lag between log-energy envelopes (1 ms hops) of the two tails.
    def envelope(x: np.ndarray) -> np.ndarray:
        n = len(x) // 16
        return np.log(1e-3 + (x[: n * 16].astype(float).reshape(n, 16) ** 2).mean(axis=1))

    before, after = envelope(hello.samples), envelope(longer.samples)
    c = round(hello.phones[k + 1].start * rate) // 16
    tail = before[c : c + 150]
    scores = [np.corrcoef(tail, after[c + lag : c + lag + 150])[0, 1] for lag in range(80)]
    assert abs(int(np.argmax(scores)) - 40) <= 5 and max(scores) > 0.8


def test_resynthesis_follows_dictated_durations_exactly(
    festival: FestivalBackend, hello: Utterance
) -> None:
    durations = np.linspace(0.05, 0.2, len(hello.phones))
    out = festival.resynthesize(hello, durations)
    assert np.allclose(out.durations(), durations, atol=1.5e-6)
    assert len(out.samples) == round(out.phones[-1].end * out.rate)


def test_resynthesis_is_as_loud_as_synthesis(festival: FestivalBackend, hello: Utterance) -> None:
    # the kal voice rescales its wave in an after-synth hook; a re-synthesis that
    # skipped the hooks came out 2.6 times quieter
    again = festival.resynthesize(hello, hello.durations())
    level = np.abs(hello.samples.astype(float)).max()
    assert abs(np.abs(again.samples.astype(float)).max() - level) < 0.02 * level


@pytest.mark.parametrize("max_words", [40, 3])
def test_retimed_synthesis_equals_synthesis_then_resynthesis(max_words: int) -> None:
    festival = FestivalBackend(max_words=max_words)
    text = "One wide boat. The lazy dog sleeps."
    plain = festival.synthesize(text)
    seen: list[tuple] = []
    kept = festival.synthesize_retimed(text, lambda phones: seen.append(phones))
    assert seen == [plain.phones]  # retime saw exactly the phones synthesis gives
    assert np.array_equal(kept.samples, plain.samples) and kept.phones == plain.phones
    durations = np.array(plain.durations())
    durations[2] += 0.05
    durations[-3] += 0.12
    twice = festival.resynthesize(plain, durations)
    once = festival.synthesize_retimed(text, lambda phones: durations)
    assert np.array_equal(once.samples, twice.samples)
    assert once.phones == twice.phones and once.chunks == twice.chunks
    assert np.allclose(once.durations(), durations, atol=1.5e-6)


def test_retimed_synthesis_passes_errors_through(festival: FestivalBackend) -> None:
    class Stop(Exception):
        pass

    def fail(phones: tuple) -> None:
        raise Stop

    with pytest.raises(Stop):
        festival.synthesize_retimed("Hello world", fail)
    with pytest.raises(MiketalkError, match="durations given"):
        festival.synthesize_retimed("Hello world", lambda phones: [0.1, 0.2])
    with pytest.raises(MiketalkError, match="positive"):
        festival.synthesize_retimed("Hello world", lambda phones: [0.0] * len(phones))
    with pytest.raises(MiketalkError, match="nothing to speak"):
        festival.synthesize_retimed("   ", lambda phones: None)


def test_resynthesis_rejects_bad_durations(festival: FestivalBackend, hello: Utterance) -> None:
    with pytest.raises(MiketalkError, match="durations given"):
        festival.resynthesize(hello, [0.1, 0.2])
    with pytest.raises(MiketalkError, match="positive"):
        festival.resynthesize(hello, [0.1] * (len(hello.phones) - 1) + [-1.0])


INJECTION = '") (system "touch /tmp/x") ("'


def test_scheme_injection_is_spoken_not_run(festival: FestivalBackend, tmp_path: Path) -> None:
    def state(path: Path) -> int | None:  # None: absent; else its mtime (touch changes it)
        return path.stat().st_mtime_ns if path.exists() else None

    target = Path("/tmp/x")  # the string names it; it may exist for other reasons
    before = state(target)
    mine = tmp_path / "injected"  # a target that certainly does not exist yet
    utt = festival.synthesize(INJECTION)
    festival.synthesize(INJECTION.replace("/tmp/x", str(mine)))
    names = [p.name for p in utt.phones]
    assert state(target) == before and not mine.exists()
    # "system" and "touch" are spoken as words
    assert names[1:7] == ["s", "ih", "s", "t", "ax", "m"]
    assert "ch" in names
    # the same through a file given to the CLI
    text_file = tmp_path / "inject.txt"
    text_file.write_text(INJECTION + "\n" + f'(system "touch {mine}")')
    out = subprocess.run(
        [sys.executable, "-m", "miketalk.cli", "phones", "-f", str(text_file), "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(out.stdout)["phones"]
    assert state(target) == before and not mine.exists()


@pytest.mark.parametrize("text", ["", "   \n\t ", "?!...", '"("', "—…"])
def test_nothing_to_speak_is_a_clear_error(festival: FestivalBackend, text: str) -> None:
    with pytest.raises(MiketalkError, match="nothing to speak"):
        festival.synthesize(text)


def test_non_ascii_is_transliterated(festival: FestivalBackend) -> None:
    assert normalize_text("café naïve Straße “déjà vu”") == "cafe naive Strasse deja vu"
    assert [p.name for p in festival.synthesize("café").phones] == [
        p.name for p in festival.synthesize("cafe").phones
    ]


def test_untransliterable_characters_are_reported(caplog: pytest.LogCaptureFixture) -> None:
    assert normalize_text("I ❤ tea") == "I tea"
    assert "❤" in caplog.text


def test_ten_thousand_words(festival: FestivalBackend) -> None:
    rng = np.random.default_rng(0)
    vocab = "the quick brown fox jumps over a lazy dog while seven children sing".split()
    sentences = [" ".join(rng.choice(vocab, 10)).capitalize() + "." for _ in range(1000)]
    text = " ".join(sentences)
    assert len(text.split()) == 10_000
    utt = festival.synthesize(text)
    assert len(utt.chunks) > 1
    assert len(utt.samples) == round(utt.phones[-1].end * utt.rate)
    starts = np.array([p.start for p in utt.phones])
    ends = np.array([p.end for p in utt.phones])
    assert np.all(ends > starts) and np.array_equal(starts[1:], ends[:-1])
    # each chunk's wav is placed exactly where its phones say it starts
    first = festival.synthesize(utt.chunks[0][0])
    assert np.array_equal(utt.samples[: len(first.samples)], first.samples)
    n0 = utt.chunks[0][1]
    assert utt.phones[n0].start * utt.rate == pytest.approx(len(first.samples), abs=1e-6)


def test_split_chunks_keeps_sentences_and_every_word() -> None:
    text = "One two three. Four five! " + " ".join(["word"] * 95) + ". Six?"
    chunks = split_chunks(text, max_words=40)
    assert all(len(c.split()) <= 40 for c in chunks)
    assert " ".join(chunks).split() == text.split()
    assert split_chunks("Hello. ... ! Bye.", max_words=40) == ["Hello. Bye."]


def test_festival_missing_names_the_packages(tmp_path: Path) -> None:
    backend = FestivalBackend(executable=str(tmp_path / "no-such-festival"))
    assert not backend.is_available()
    with pytest.raises(MiketalkError, match="apt-get install -y festival festvox-kallpc16k"):
        backend.synthesize("hello")


def test_festival_missing_from_path(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("MIKETALK_FESTIVAL", raising=False)
    with pytest.raises(MiketalkError, match="festvox-kallpc16k"):
        FestivalBackend().synthesize("hello")


def _fake_festival(directory: Path, script: str) -> str:
    """An executable ``festival`` in ``directory`` running the shell ``script``."""
    directory.mkdir(parents=True, exist_ok=True)
    fake = directory / "festival"
    fake.write_text("#!/bin/sh\n" + script)
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    return str(fake)


_CRASH = "echo 'Segmentation fault' >&2\nexit 139\n"
_PLAN = "echo 'pau 0.2' > \"$MIKETALK_OUT/0.plan\"\necho 'miketalk: planned' >&2\n"


def test_festival_crash_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(MiketalkError, match="Festival failed"):
        FestivalBackend(executable=_fake_festival(tmp_path, _CRASH)).synthesize("hello")


@pytest.mark.parametrize(
    "script",
    [_CRASH, _PLAN + "exec 0<&-\necho 'SIOD ERROR: oops' >&2\nexit 1\n"],
    ids=["crashes", "dies-after-planning"],
)
def test_festival_failing_in_a_retimed_run_is_a_clear_error(tmp_path: Path, script: str) -> None:
    backend = FestivalBackend(executable=_fake_festival(tmp_path, script))
    with pytest.raises(MiketalkError, match="Festival failed"):
        backend.synthesize_retimed("hello", lambda phones: None)


def test_festival_hanging_in_a_retimed_run_is_stopped(tmp_path: Path, finishes) -> None:
    # plans, is told to go, and then sleeps for ten minutes, its pid noted
    pid = tmp_path / "festival.pid"
    hang = _PLAN + f"echo $$ > {pid}\nexec sleep 600\n"
    backend = FestivalBackend(executable=_fake_festival(tmp_path, hang), timeout=2.0)
    with pytest.raises(MiketalkError, match="took longer than 2 s"):
        finishes(lambda: backend.synthesize_retimed("hello", lambda phones: None))
    assert not Path(f"/proc/{pid.read_text().strip()}").exists()  # killed, not left asleep


def test_started_festival_runs_while_the_caller_works_and_is_cleaned_up(
    festival: FestivalBackend, hello: Utterance
) -> None:
    with festival.start("Hello world") as speech:
        proc, tmp = speech._proc, speech._tmp
        assert proc is not None and proc.poll() is None  # Festival started at once
        assert speech.finish(lambda phones: None).phones == hello.phones
        assert not tmp.exists()  # finish removed the scratch directory
        with pytest.raises(MiketalkError, match="already finished"):
            speech.finish(lambda phones: None)


def test_closing_a_started_festival_stops_it(tmp_path: Path, finishes) -> None:
    backend = FestivalBackend(executable=_fake_festival(tmp_path, _PLAN + "exec sleep 600\n"))

    def start_and_close():
        with backend.start("hello") as speech:
            return speech._proc, speech._tmp

    proc, tmp = finishes(start_and_close)  # closing waits for no ten-minute sleep
    assert proc.poll() is not None and not tmp.exists()


def test_start_rejects_empty_text_before_running_festival(tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    backend = FestivalBackend(executable=_fake_festival(tmp_path, f"touch {marker}\n"))
    with pytest.raises(MiketalkError, match="nothing to speak"):
        backend.start("  ?! ")
    assert not marker.exists()


def test_heap_is_passed_to_festival_and_checked(tmp_path: Path) -> None:
    args = tmp_path / "args"
    script = f'echo "$@" > {args}\n' + _PLAN + "exit 1\n"
    backend = FestivalBackend(executable=_fake_festival(tmp_path, script), heap=2_000_000)
    with pytest.raises(MiketalkError):
        backend.synthesize_retimed("hello", lambda phones: None)
    assert args.read_text().split()[:2] == ["--heap", "2000000"]
    for bad in (0, 99_999, 1.5e6, True):
        with pytest.raises(MiketalkError, match="heap"):
            FestivalBackend(heap=bad)


def test_version(festival: FestivalBackend) -> None:
    assert festival.version()[0].isdigit()


def test_cli_phones_prints_visemes_and_zero_offset() -> None:
    env = dict(os.environ)
    out = subprocess.run(
        [sys.executable, "-m", "miketalk.cli", "phones", "Hello world"],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    ).stdout
    assert "o-ou+u" in out and "wav - last end = 0 samples" in out
    bad = subprocess.run(
        [sys.executable, "-m", "miketalk.cli", "phones", "  "], capture_output=True, text=True
    )
    assert bad.returncode == 2
    assert "Traceback" not in bad.stderr and "nothing to speak" in bad.stderr


def test_a_word_longer_than_festival_reads_is_refused_before_it_runs(tmp_path: Path) -> None:
    from miketalk.speech.text import MAX_WORD

    never = FestivalBackend(_fake_festival(tmp_path, f"touch '{tmp_path}/ran'; exit 1"))
    word = "supercalifragilistic" * 500
    for text in (word, f"Say {word} now.", "1" * (MAX_WORD + 1)):
        with pytest.raises(
            MiketalkError, match=f"letters long; Festival reads words of up to {MAX_WORD}"
        ):
            never.start(text)
        with pytest.raises(MiketalkError, match="letters long"):
            never.synthesize(text)
    assert not (tmp_path / "ran").exists()
    assert normalize_text("a" * MAX_WORD) == "a" * MAX_WORD


@pytest.mark.parametrize(("voice", "rate"), [("kal", 16000), ("ked", 16000), ("slt", 32000)])
def test_each_voice_speaks_radio_phones_with_sound_and_phones_ending_together(
    voice: str, rate: int
) -> None:
    backend = FestivalBackend(voice=voice)
    text = "Hello world. Her bird."
    planned: list = []
    with backend.start(text) as speech:
        utterance = speech.finish(lambda phones: planned.append(phones))
    assert utterance.rate == rate
    assert len(utterance.samples) == round(utterance.phones[-1].end * rate)
    names = [p.name for p in utterance.phones]
    assert names == [p.name for p in planned[0]]  # ked's er + r is spoken as er
    assert names[:5] == ["pau", "hh", "ax", "l", "ow"] and "er" in names
    assert np.abs(utterance.samples.astype(int)).max() > 1000


def test_the_hts_voice_cannot_be_dictated_durations() -> None:
    slt = FestivalBackend(voice="slt")
    utterance = slt.synthesize("Hello world.")
    with pytest.raises(MiketalkError, match="slt voice sets its own phone durations"):
        slt.resynthesize(utterance, [2 * d for d in utterance.durations()])
    with slt.start("Hello world.") as speech, pytest.raises(MiketalkError, match="its own phone"):
        speech.finish(lambda phones: [0.1] * len(phones))
    with pytest.raises(
        MiketalkError, match=r"unknown voice 'bob'; known: kal \(festvox-kallpc16k\)"
    ):
        FestivalBackend(voice="bob")
    assert FestivalBackend(voice="voice_kal_diphone").voice.name == "kal"


def test_a_missing_voice_names_its_package(tmp_path: Path) -> None:
    script = "echo 'SIOD ERROR: unbound variable : voice_ked_diphone' >&2; exit 1"
    backend = FestivalBackend(_fake_festival(tmp_path, script), voice="ked")
    with pytest.raises(MiketalkError, match="apt-get install -y festival festvox-kdlpc16k"):
        backend.synthesize("Hello")
