"""The utterance as a stream (issue 51): the same frames live as in the file, a bounded
queue between the engine and its reader, and a stop that ends every process at once.

The model is :func:`test_cli.shifted_model` (one texture shifted per viseme, exact flows).
No assertion reads a clock: a stop is waited for with a deadline on a poll.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from miketalk import api
from miketalk.media.video import ffmpeg_exe
from miketalk.talk.stream import Cancelled, Chunk, Stream, StreamInfo

TEXT = "Hello there. The face says this, sentence by sentence."
LONG = " ".join(["One wide boat sails by the old house, and the lazy dog sleeps."] * 4)


@pytest.fixture(scope="module")
def face(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from test_cli import shifted_model

    return shifted_model(tmp_path_factory.mktemp("face"), 64)


def cli(*args: object, cwd: Path, stdout=subprocess.PIPE) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "miketalk.cli", *map(str, args)], cwd=cwd, stdout=stdout,
        stderr=subprocess.PIPE, timeout=300, check=False,
    )  # fmt: skip


def decoded(path: Path, stream: str) -> list[str]:
    """The MD5 of each decoded video frame, or the decoded sound's bytes' as one."""
    if stream == "a":
        proc = subprocess.run(
            [ffmpeg_exe(), "-v", "error", "-i", str(path), "-map", "0:a", "-f", "s16le", "-"],
            capture_output=True, check=True,
        )  # fmt: skip
        return [proc.stdout]
    proc = subprocess.run(
        [ffmpeg_exe(), "-v", "error", "-i", str(path), "-map", "0:v", "-f", "framemd5", "-"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    return [line.split(",")[-1].strip() for line in proc.stdout.splitlines() if line[:1] != "#"]


def until(condition, *, within: float = 60.0, what: str = "the condition") -> None:
    """Poll ``condition()`` until it holds; fail the test after ``within`` seconds."""
    deadline = time.monotonic() + within
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"{what} did not happen within {within} s")
        time.sleep(0.02)


def descendants() -> set[int]:
    """The live processes under this one (children of any of its threads, and theirs)."""
    found: set[int] = set()
    todo = [os.getpid()]
    while todo:
        pid = todo.pop()
        try:
            tasks = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        for task in tasks:
            try:
                children = Path(f"/proc/{pid}/task/{task}/children").read_text().split()
            except OSError:
                continue
            for child in map(int, children):
                if child not in found and not zombie(child):
                    found.add(child)
                    todo.append(child)
    return found


def zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True  # gone


# ---------------------------------------------------------------------------
# live is the file: the same frames (live's x264 settings on the pipe)
# ---------------------------------------------------------------------------


def rgb_frames(path: Path, side: int) -> np.ndarray:
    """Every decoded video frame of ``path`` (``side`` x ``side``), RGB, as one array."""
    proc = subprocess.run(
        [ffmpeg_exe(), "-v", "error", "-i", str(path), "-map", "0:v", "-f", "rawvideo",
         "-pix_fmt", "rgb24", "-"],
        capture_output=True, check=True,
    )  # fmt: skip
    return np.frombuffer(proc.stdout, np.uint8).reshape(-1, side, side, 3)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)


def x264_options(path: Path) -> dict[str, str]:
    """The settings x264 wrote into the stream's first SEI ("... bframes=3 ... crf=18.0")."""
    data = path.read_bytes()
    start = data.index(b"x264 - core")
    text = data[start : data.index(b"\0", start)].decode("ascii", "replace")
    return dict(item.split("=", 1) for item in text.split() if "=" in item)


def test_the_frames_of_o_dash_are_those_of_the_file(face: Path, tmp_path: Path) -> None:
    # -o - is the live stream: x264's live settings (no look-ahead, no B-frames); -o FILE
    # keeps the file's. The frames are the same ones, each within the live encoding's loss.
    made = cli("say", TEXT, "-o", "file.mp4", "--model", face, cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    with (tmp_path / "pipe.mp4").open("wb") as out:
        piped = cli("say", TEXT, "-o", "-", "--model", face, cwd=tmp_path, stdout=out)
    assert piped.returncode == 0, piped.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.json", "file.mp4", "pipe.mp4"]
    assert b"moof" in (tmp_path / "pipe.mp4").read_bytes()  # fragmented: playable as it comes
    assert b"moof" not in (tmp_path / "file.mp4").read_bytes()
    live, kept = x264_options(tmp_path / "pipe.mp4"), x264_options(tmp_path / "file.mp4")
    assert (live["bframes"], live["mbtree"], live["crf"]) == ("0", "0", "20.0")
    assert "rc_lookahead" not in live  # ultrafast: no look-ahead to wait for
    assert (kept["bframes"], kept["rc_lookahead"], kept["crf"]) == ("3", "10", "18.0")
    frames, piped_frames = (
        rgb_frames(tmp_path / "file.mp4", 64),
        rgb_frames(tmp_path / "pipe.mp4", 64),
    )
    assert len(frames) > 30 and len(set(decoded(tmp_path / "file.mp4", "v"))) > 5  # it moves
    assert piped_frames.shape == frames.shape
    # this face's texture is noise: 31-35 dB between the two encodings at 64x64 (45 dB at 720p)
    assert min(psnr(a, b) for a, b in zip(piped_frames, frames, strict=True)) > 28
    # each is its own frame, not a neighbour: where the face moves, the frame of the same
    # index is nearer than the next one
    moving = [k for k in range(len(frames) - 1) if psnr(frames[k], frames[k + 1]) < 30]
    assert len(moving) > 5
    assert all(
        psnr(piped_frames[k], frames[k]) > psnr(piped_frames[k], frames[k + 1]) for k in moving
    )
    # the sound too, up to the file's end (the fragments keep the last AAC packet whole)
    sound = decoded(tmp_path / "file.mp4", "a")[0]
    assert decoded(tmp_path / "pipe.mp4", "a")[0][: len(sound)] == sound
    assert "-: " in piped.stderr.decode() and "timeline in" not in piped.stderr.decode()


def test_a_reader_that_goes_away_ends_the_say_quietly(face: Path, tmp_path: Path) -> None:
    command = (
        f"{sys.executable} -m miketalk.cli say '{LONG}' -o - --model {face} 2> err.txt "
        "| head -c 1000 > /dev/null; echo ${PIPESTATUS[0]}"
    )
    proc = subprocess.run(
        command, shell=True, executable="/bin/bash", cwd=tmp_path, capture_output=True,
        text=True, timeout=300, check=False,
    )  # fmt: skip
    assert proc.stdout.strip() == "0"  # as `miketalk cues ... | head`: the reader chose to stop
    assert (tmp_path / "err.txt").read_text() == ""


def test_o_dash_on_a_terminal_is_one_line(face: Path, tmp_path: Path) -> None:
    import pty

    leader, follower = pty.openpty()
    try:
        proc = cli("say", "Hi.", "-o", "-", "--model", face, cwd=tmp_path, stdout=follower)
    finally:
        os.close(follower)
        os.close(leader)
    assert proc.returncode == 2
    assert proc.stderr.decode().strip().splitlines() == [
        "miketalk: error: -o - writes the video on stdout: pipe it into a player (| ffplay -) "
        "or a file, not a terminal"
    ]


def test_the_stream_gives_each_frame_its_sound(face: Path) -> None:
    settings = api.SaySettings(model=str(face), fps=25)
    with api.say_stream(TEXT, settings) as stream:
        info = stream.info()
        chunks = list(stream)
    assert (info.fps, info.rate, info.sound, info.frames) == (25, 16000, None, None)
    assert [c.index for c in chunks] == list(range(len(chunks)))
    assert all(len(c.audio) == 640 for c in chunks)  # 16000 / 25 samples a frame
    assert all(c.frame.shape == (64, 64, 3) and c.frame.dtype == np.uint8 for c in chunks)
    said = stream.result
    assert len(said.timeline.frames) == len(chunks)
    joined = np.concatenate([c.audio for c in chunks])
    sound = said.utterance.samples
    assert np.array_equal(joined[: len(sound)], sound[: len(joined)])
    assert abs(len(joined) - len(sound)) <= 320  # fitted to whole frames: half a frame


# ---------------------------------------------------------------------------
# back-pressure: a reader that does not read holds the engine
# ---------------------------------------------------------------------------


def test_a_reader_that_stops_reading_holds_the_engine(face: Path) -> None:
    stream = api.say_stream(LONG, api.SaySettings(model=str(face)))
    with stream:
        stream.info()
        until(lambda: stream.made >= api.QUEUE_CHUNKS, what="a full queue")
        time.sleep(0.5)  # the engine's chance to run ahead (not a measure of anything)
        assert stream.made == api.QUEUE_CHUNKS
        ahead = 0
        read = 0
        for _ in stream:
            read += 1
            ahead = max(ahead, stream.made - read)
    assert read == stream.made > 4 * api.QUEUE_CHUNKS
    assert ahead <= api.QUEUE_CHUNKS


# ---------------------------------------------------------------------------
# a stop ends the work and every process
# ---------------------------------------------------------------------------


def _hanging_festival(directory: Path) -> Path:
    """A ``festival`` that starts a child of its own and sleeps: both pids noted."""
    directory.mkdir(parents=True, exist_ok=True)
    fake = directory / "festival"
    fake.write_text(
        "#!/bin/sh\n"
        f"sleep 600 & echo $! > {directory}/child.pid\n"
        f"echo $$ > {directory}/festival.pid\n"
        "wait\n"
    )
    fake.chmod(0o755)
    return fake


def test_a_stop_while_festival_speaks_kills_it_and_its_children(
    face: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MIKETALK_FESTIVAL", str(_hanging_festival(tmp_path / "bin")))
    before = descendants()
    stream = api.say_stream(TEXT, api.SaySettings(model=str(face))).start()
    until(lambda: (tmp_path / "bin" / "child.pid").exists(), what="Festival's start")
    until(lambda: (tmp_path / "bin" / "festival.pid").exists(), what="Festival's start")
    pids = [int((tmp_path / "bin" / f"{n}.pid").read_text()) for n in ("festival", "child")]
    assert not any(zombie(p) for p in pids)  # both run
    stream.cancel()
    until(lambda: all(zombie(p) for p in pids), within=30, what="the kill of Festival")
    assert stream.wait(30)  # the engine unwound
    with pytest.raises(Cancelled):
        stream.info()
    stream.close()
    assert descendants() <= before


def test_a_stop_while_the_pipe_is_written_ends_ffmpeg(face: Path) -> None:
    before = descendants()
    stream = api.say_stream(LONG, api.SaySettings(model=str(face)))
    read_end, write_end = os.pipe()
    outcome: dict = {}

    def write() -> None:
        try:
            api.write_fragmented(stream, write_end)
        except BaseException as err:  # handed to the test
            outcome["error"] = err

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    first = os.read(read_end, 1 << 16)  # the stream's first bytes: the work is under way
    assert first[4:8] == b"ftyp"
    assert descendants() - before  # ffmpeg runs
    stream.cancel()
    writer.join(60)
    assert not writer.is_alive()
    assert isinstance(outcome.get("error"), Cancelled)
    os.close(write_end)
    while os.read(read_end, 1 << 16):  # what ffmpeg wrote before it was killed
        pass
    os.close(read_end)
    until(lambda: descendants() <= before, within=30, what="the end of every child")


# ---------------------------------------------------------------------------
# the stream itself
# ---------------------------------------------------------------------------


def _frames(n: int, *, fail: Exception | None = None):
    def produce(emitter) -> str:
        emitter.info(StreamInfo(fps=10, rate=100))
        for k in range(n):
            emitter.emit(Chunk(k, np.zeros((2, 2, 3), np.uint8), np.zeros(10, np.int16), 10))
        if fail is not None:
            raise fail
        return "done"

    return produce


def test_a_stream_hands_over_its_chunks_then_its_result() -> None:
    with Stream(_frames(50), maxsize=3) as stream:
        assert [c.index for c in stream] == list(range(50))
    assert stream.result == "done"
    assert [c.time for c in Stream(_frames(3))] == [0.0, 0.1, 0.2]


def test_an_engine_error_reaches_the_reader_after_the_chunks_before_it() -> None:
    read = []
    with pytest.raises(api.MiketalkError, match="no voice"):
        with Stream(_frames(5, fail=api.MiketalkError("no voice"))) as stream:
            read.extend(c.index for c in stream)
    assert read == [0, 1, 2, 3, 4]


def test_a_cancel_from_another_thread_stops_a_waiting_reader() -> None:
    started = threading.Event()

    def produce(emitter) -> None:
        emitter.info(StreamInfo(fps=10, rate=100))
        started.set()
        while True:  # an engine that never emits: only the stop ends it
            emitter.check()
            time.sleep(0.01)

    stream = Stream(produce).start()
    threading.Thread(target=lambda: started.wait(30) and stream.cancel(), daemon=True).start()
    with pytest.raises(Cancelled):
        list(stream)
    assert stream.wait(30)


# ---------------------------------------------------------------------------
# long text: sentence by sentence, Festival one sentence ahead, joined without a seam
# ---------------------------------------------------------------------------

THREE = "Pop the big bubble now. Peter picks a pepper at noon. Bob bought a blue map."


@pytest.fixture(scope="module")
def learned_face(face: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shifted face with the prior's learned coarticulation (whose mouth, weighed by
    the keyframes around it, anticipates a sentence's first lip closure)."""
    import shutil

    from miketalk.draw.coarticulation import CoarticulationParams
    from miketalk.model.write import write_coarticulation
    from miketalk.visemes import VisemeTable

    learned = tmp_path_factory.mktemp("learned") / "model"
    shutil.copytree(face, learned)
    write_coarticulation(learned, CoarticulationParams.prior(VisemeTable().visemes, lead=0.02))
    return learned


def test_festival_speaks_the_next_sentences_while_the_face_draws(
    face: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    stream = api.say_stream(THREE, api.SaySettings(model=str(face)))
    with stream:
        chunks = iter(stream)
        next(chunks)  # the first frame of the first sentence; the reader stops there
        # the face draws sentence 0 (held by the queue) knowing sentence 1; Festival has
        # spoken sentence 2 meanwhile: its text file is removed once its wave is read
        until(lambda: not list(tmp_path.glob("miketalk-festival-*/2.txt")),
              what="Festival's speaking of the third sentence")  # fmt: skip
        assert list(tmp_path.glob("miketalk-festival-*/0.txt")) == []
        assert stream.made <= api.QUEUE_CHUNKS + 1  # the face is still on sentence 0
        rest = list(chunks)
    said = stream.result
    assert [text for text, _ in said.utterance.chunks] == [
        "Pop the big bubble now.", "Peter picks a pepper at noon.", "Bob bought a blue map."
    ]  # fmt: skip
    assert len(rest) + 1 == len(said.timeline.frames) > api.QUEUE_CHUNKS + 1


def test_sentences_join_into_one_timeline_without_a_jump(learned_face: Path, tmp_path: Path):
    import json

    from miketalk.media.video import probe_durations

    settings = api.SaySettings(model=str(learned_face), lipsync_model="learned")
    said = api.say(THREE, tmp_path / "three.mp4", settings)
    assert len(said.spoken.utterance.chunks) == 3
    # the step limit holds across the sentences' edges too (a mouth drawn from each
    # sentence alone jumped there: 9 px on s1)
    assert said.motion.largest_step_px <= 2.5 + 1e-6
    doc = json.loads((tmp_path / "three.json").read_text())
    frames = doc["frames"]
    assert [f["index"] for f in frames] == list(range(len(frames)))
    assert all(f["time"] == f["index"] / doc["fps"] for f in frames)
    phones = doc["phones"]
    assert phones[0]["start"] == 0.0 and phones[-1]["end"] == doc["duration"]
    assert all(a["end"] == b["start"] for a, b in pairwise(phones))
    assert abs(doc["duration"] - len(frames) / doc["fps"]) < 1e-3
    video, audio = probe_durations(tmp_path / "three.mp4")
    assert abs(video - audio) < 1e-3


def test_a_closed_ahead_kills_its_threads_process_and_waits_for_its_clean_up(
    tmp_path: Path,
) -> None:
    """The next sentence's Festival, a child of ahead()'s own thread, is killed when the
    caller stops, and close() returns once its scratch folder is gone (a say stopped by a
    signal left it behind: the process ended while the thread was still inside it)."""
    from miketalk.media.scratch import scratch_dir
    from miketalk.talk.sentences import ahead

    inside = threading.Event()
    seen: dict = {}

    def speak(i: int) -> int:  # as Festival runs: a child process inside a scratch folder
        if i == 0:
            return i
        with scratch_dir("festival", directory=tmp_path) as scratch:
            proc = subprocess.Popen(["sleep", "60"])
            seen.update(proc=proc, scratch=scratch)
            inside.set()
            if proc.wait() != 0:
                raise RuntimeError("festival was killed")
        return i

    said = ahead(speak(i) for i in range(3))
    assert next(said) == 0  # sentence 0 said; the thread now speaks sentence 1
    assert inside.wait(60)
    said.close()
    assert seen["proc"].poll() == -9
    assert not seen["scratch"].exists() and list(tmp_path.iterdir()) == []


def test_the_first_frame_comes_before_the_second_sentence_is_spoken(
    learned_face: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import miketalk.talk.say as say_module

    read_first = threading.Event()
    waited = []
    made = say_module.ahead

    def held(items, **options):  # the second sentence is spoken only once a frame was read
        def second_held():
            for i, item in enumerate(items):
                if i == 1:
                    waited.append(read_first.wait(120))
                yield item

        return made(second_held(), **options)

    monkeypatch.setattr(say_module, "ahead", held)
    settings = api.SaySettings(model=str(learned_face), lipsync_model="learned")
    with api.say_stream(THREE, settings) as stream:
        chunks = iter(stream)
        first = next(chunks)
        read_first.set()
        rest = list(chunks)
    # the face played the first sentence's frames before the second was known
    assert first.index == 0 and waited == [True]
    assert len(rest) + 1 == len(stream.result.timeline.frames)


def test_a_sentence_drawn_before_the_next_is_known_is_drawn_as_knowing_it(
    learned_face: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import miketalk.talk.say as say_module
    from miketalk.draw.learned import learned_exposures
    from miketalk.draw.registry import LearnedDrawing
    from miketalk.model.face import open_model
    from miketalk.talk.sentences import in_context

    seen = []
    monkeypatch.setattr(
        say_module, "in_context", lambda t, b, a: seen.append((t, b, a)) or in_context(t, b, a)
    )
    api.say(THREE, tmp_path / "three.mp4", api.SaySettings(model=str(learned_face)))
    model = open_model(learned_face)
    drawing = LearnedDrawing(model.coarticulation)
    known = [(t, b, a) for t, b, a in seen if a is not None]
    assert len(known) == 2  # the first two sentences' ends, drawn once the next was known
    for timeline, before, after in known:
        head = drawing.settled(timeline)
        assert 0 < head < len(timeline.frames)
        alone, knowing = (
            learned_exposures(in_context(timeline, before, a), model.coarticulation,
                              displacement=model.displacement, max_px_per_frame=2.5)
            for a in (None, after)
        )  # fmt: skip
        assert alone[:head] == knowing[:head]  # the frames played before `after` was known
        assert alone != knowing  # and the next sentence does change the sentence's end


def test_the_live_encoder_keeps_up_with_frames_slower_than_real_time(tmp_path: Path) -> None:
    # with x264's zerolatency tune, ffmpeg stopped reading both its pipes for good once the
    # frames came slower than they play (the page's 720p stream hung at its first frame)
    from miketalk.media.encoder import StreamEncoder
    from miketalk.media.x264 import LIVE_X264
    from miketalk.media.yuv import I420Frame

    read_end, write_end = os.pipe()
    out = bytearray()

    def read() -> None:
        while block := os.read(read_end, 1 << 16):
            out.extend(block)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    rng = np.random.default_rng(0)
    encoder = StreamEncoder(write_end, fps=29.97, rate=16000, log_path=tmp_path / "ffmpeg.log",
                            x264=LIVE_X264)  # fmt: skip
    ended = threading.Event()

    def write() -> None:
        with encoder:
            for _ in range(40):
                time.sleep(0.05)  # 20 frames a second, for a video of 30
                planes = rng.integers(0, 256, (720 * 3 // 2, 1280), np.uint8)
                encoder.add(I420Frame(planes), np.zeros(533, np.int16))  # as composited
            encoder.finish()
        ended.set()

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    try:
        until(ended.is_set, within=60, what="the live encoder's end")
    finally:
        encoder.kill()
        os.close(write_end)
    reader.join(10)
    os.close(read_end)
    got = tmp_path / "live.mp4"
    got.write_bytes(bytes(out))
    assert len(decoded(got, "v")) == 40


def test_the_sentences_sound_is_held_once_for_the_result() -> None:
    """The joined utterance's sound (an hour's: 115 MB at 16 kHz) is the sentences' sound
    appended in one buffer as they are spoken, read without a copy: joining a list of
    pieces at the end held it twice."""
    import tracemalloc

    from miketalk.lipsync.timeline import FrameSample, Timeline
    from miketalk.speech.types import Phone, Utterance
    from miketalk.talk.sentences import Joined

    rate, fps, n = 16000, 25.0, 50
    joined, pieces = Joined(fps), []
    for k in range(30):
        phones = (Phone("pau", 0.0, n / fps),)
        samples = np.arange(n * rate // 25, dtype=np.int16) + k  # 2 s a sentence
        frames = tuple(FrameSample(i, i / fps, 0, 0.0) for i in range(n))
        joined.add(Utterance(f"s{k}", samples, rate, phones),
                   Timeline(fps, n / fps, phones, (), (), frames), phones)  # fmt: skip
        pieces.append(samples)
    tracemalloc.start()
    said = joined.utterance("all")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    whole = np.concatenate(pieces)
    np.testing.assert_array_equal(said.samples, whole)
    assert said.samples.dtype == np.int16 and said.duration == pytest.approx(60.0)
    assert whole.nbytes > 1_000_000 and peak < whole.nbytes / 10


def test_a_closed_stream_gives_the_memory_its_engine_freed_back() -> None:
    """glibc keeps what a thread freed in its arena, resident: a server that has spoken an
    hour held the largest job's working memory for good. A closed stream gives it back."""
    code = """
import numpy as np
from miketalk.talk.stream import Chunk, Stream, StreamInfo

def rss_mb():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024

kept = []

def produce(emitter):
    emitter.info(StreamInfo(fps=10, rate=100))
    work = [bytes(4000) for _ in range(50_000)]  # 200 MB in pieces malloc holds in its arena
    kept.extend(work[::10])  # what the result keeps, spread among what is freed
    del work[:]
    emitter.emit(Chunk(0, np.zeros((2, 2, 3), np.uint8), np.zeros(10, np.int16), 10))

stream = Stream(produce)
list(stream)
before = rss_mb()
stream.close()
print(before, rss_mb())
"""
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    before, after = map(float, proc.stdout.split())
    assert before > 150  # the freed pieces still resident before the close
    assert after < before - 100  # 180 MB of the 200 were freed: most of it given back
