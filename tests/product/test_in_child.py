"""Work started in a forked child now, its result taken later (:class:`miketalk.workers.
InChild`): a dub aligns its recording there while its video registers."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from miketalk.errors import MiketalkError
from miketalk.talk.recorded import aligning
from miketalk.talk.speech import Recorded
from miketalk.talk.stream import Cancelled, Stream, StreamInfo
from miketalk.workers import InChild, run_in_child


def _pid_and(value: int) -> tuple[int, int]:
    return os.getpid(), value * 2


def _pid_of_nested() -> tuple[int, int]:
    """This process's pid and the pid ``run_in_child`` ran its function in."""
    return os.getpid(), run_in_child(_pid_and, 1)[0]


def _fails(message: str) -> None:
    raise MiketalkError(message)


def _sleeps(seconds: float) -> None:
    time.sleep(seconds)


def _gone(pid: int) -> bool:
    """Reaped (no such process) or a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def _until(condition, within: float = 30.0) -> None:
    deadline = time.monotonic() + within
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"not within {within} s")
        time.sleep(0.02)


def test_the_result_is_made_in_another_process_and_taken_later():
    with InChild(_pid_and, 21) as pending:
        child = pending._pid
        assert child is not None and child != os.getpid()
        pid, value = pending.result()
    assert (pid, value) == (child, 42) and _gone(child)
    assert run_in_child(_pid_and, 4)[1] == 8
    with pytest.raises(MiketalkError, match="taken"):
        pending.result()


def test_run_in_child_inside_a_child_runs_there_and_forks_again_elsewhere():
    """A forked child (killed by its parent, its signals' default actions) runs
    run_in_child's function itself: a dub's alignment keeps its loaded aligner."""
    with InChild(_pid_of_nested) as pending:
        child = pending._pid
        outer, inner = pending.result()
    assert outer == child == inner
    outer, inner = _pid_of_nested()  # here, not in such a child: a child of its own
    assert outer == os.getpid() and inner not in (outer, child)


def test_what_the_child_raises_is_raised_where_the_result_is_taken():
    with InChild(_fails, "no such word") as pending, pytest.raises(MiketalkError, match="word"):
        pending.result()


def test_a_child_whose_result_was_not_taken_is_killed_on_leaving_the_block():
    with InChild(_sleeps, 600) as pending:
        child = pending._pid
        assert child is not None and not _gone(child)
    assert _gone(child)
    pending.cancel()  # again: nothing


def test_a_streams_stop_kills_a_child_its_producer_started():
    """Started from the producer's thread, the child is the stream's to kill (as Festival
    and ffmpeg are): a stopped dub leaves no aligner running."""
    started: dict = {}

    def produce(emitter):
        emitter.info(StreamInfo(fps=10, rate=100))
        with InChild(_sleeps, 600) as pending:
            started["pid"] = pending._pid
            while True:
                emitter.check()
                time.sleep(0.01)

    stream = Stream(produce, name="test").start()
    _until(lambda: "pid" in started)
    stream.cancel()
    _until(lambda: _gone(started["pid"]))
    assert stream.wait(30)
    with pytest.raises(Cancelled):
        list(stream)
    stream.close()


def test_a_recording_with_its_text_is_aligned_ahead_and_one_to_recognize_is_not(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    # whether this worker loaded the recognizer depends on the tests it ran before: both ways
    for name in ("ctranslate2", "faster_whisper"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    audio = tmp_path / "a.wav"
    assert aligning(Recorded(audio)) is None  # its words recognized: here, not forked
    assert aligning(Recorded(audio, text="bin blue", phones="recognized")) is None
    with aligning(Recorded(audio, text="bin blue")) as pending:
        assert isinstance(pending, InChild)
        with pytest.raises(MiketalkError):  # no such file: said where the result is taken
            pending.result()
    # once the recognizer is loaded, no fork (CTranslate2's threads do not survive one)
    monkeypatch.setitem(sys.modules, "ctranslate2", object())
    assert aligning(Recorded(audio, text="bin blue")) is None


def test_a_dub_aligns_its_recording_from_the_start_and_a_failed_check_leaves_no_child(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """api.dub starts the alignment before its checks (it runs while they are made and the
    video registers); a check that fails kills it on the way out."""
    import sys

    from miketalk import api
    from miketalk.api.settings import DubSettings
    from miketalk.talk import recorded

    for name in ("ctranslate2", "faster_whisper"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    started: list[int] = []

    def watched(said):
        pending = aligning(said)
        started.append(pending._pid)
        return pending

    monkeypatch.setattr(recorded, "aligning", watched)
    video, audio = tmp_path / "v.mp4", tmp_path / "a.wav"
    video.write_bytes(b"not looked at: the model is refused first")
    audio.write_bytes(b"")
    speech = Recorded(audio, text="bin blue at f two now")
    with pytest.raises(MiketalkError):
        api.dub(video, speech, tmp_path / "out.mp4", DubSettings(model=tmp_path / "no-model"))
    assert len(started) == 1 and started[0] is not None and _gone(started[0])
    assert not list(tmp_path.glob("out*"))
