"""An utterance as a stream of timed chunks: made in a thread, read in order, stopped at once.

The engine (:mod:`miketalk.talk.say`) makes an utterance in a producer thread and hands it
over one :class:`Chunk` at a time: a frame and the sound played while it shows. The
hand-over is a bounded queue (:data:`QUEUE_CHUNKS`): a consumer slower than the engine
(a pipe nobody reads, a browser on a slow link) makes the engine wait, so memory holds at
most that many frames whatever the utterance's length. :meth:`Stream.cancel`, from any
thread, ends the work: every process the producer thread started (Festival, ffmpeg,
workers, and their own children) is killed at once, the producer stops at its next frame,
and a reader gets :class:`Cancelled`.

Writers consume a stream (:mod:`miketalk.talk.publish`): the mp4 file pair, fragmented MP4
on a pipe; the page reads it the same way.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import queue
import signal
import subprocess
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "QUEUE_CHUNKS", "Cancelled", "Chunk", "Emitter", "Stream", "StreamInfo",
    "release_free_memory",
]  # fmt: skip

log = logging.getLogger(__name__)

#: Chunks (frames) the queue between the engine and its reader holds: 0.5 s at 30 fps,
#: 33 MB of 720p frames.
QUEUE_CHUNKS = 16

_POLL = 0.05  # seconds between looks at the stop while waiting on the queue
_JOIN = 5.0  # seconds a stream's close waits for its producer to unwind


class Cancelled(Exception):
    """The stream was stopped (:meth:`Stream.cancel`) before its end."""


@dataclass(frozen=True)
class StreamInfo:
    """What a stream's reader knows before its first frame.

    Attributes
    ----------
    fps : float
        Frames a second.
    rate : int
        Sample rate of each chunk's ``audio`` (Hz).
    sound : Path or None
        A recording the utterance speaks (``say --audio``, ``dub --audio``): a file writer
        encodes its sound from it, at its own rate and channels; each chunk's ``audio`` is
        the same sound decoded mono at ``rate``. None: the chunks' audio is the sound.
    frames : int or None
        How many frames the utterance has when known before the first (a recording);
        None for typed text, spoken sentence by sentence.
    """

    fps: float
    rate: int
    sound: Path | None = None
    frames: int | None = None


@dataclass(frozen=True)
class Chunk:
    """One frame of the utterance and the sound played while it shows.

    Attributes
    ----------
    index : int
        The frame's number, from 0.
    frame : numpy.ndarray or I420Frame
        ``(H, W, 3)`` RGB uint8; or, composited into video of the person, an
        :class:`~miketalk.media.yuv.I420Frame` (the encoder's own colours: only the mouth's
        box was converted). :attr:`rgb` gives RGB either way. Every frame of a stream has
        one size.
    audio : numpy.ndarray
        Mono int16 samples at :attr:`StreamInfo.rate`, from ``index / fps`` to
        ``(index + 1) / fps`` (sample ``round(index * rate / fps)`` up to
        ``round((index + 1) * rate / fps)``): the chunks' audio joined is the utterance's.
    fps : float
        The stream's frame rate.
    """

    index: int
    frame: np.ndarray
    audio: np.ndarray
    fps: float

    @property
    def rgb(self) -> np.ndarray:
        """The frame as ``(H, W, 3)`` uint8 RGB (what a player shows)."""
        return self.frame.rgb() if hasattr(self.frame, "planes") else self.frame

    @property
    def time(self) -> float:
        """When the frame shows, in seconds from the start."""
        return self.index / self.fps


_END = object()


class Emitter:
    """The producer's side of a :class:`Stream`: :meth:`info` once, then :meth:`emit`."""

    def __init__(self, stream: Stream) -> None:
        self._stream = stream

    def check(self) -> None:
        """Raise :class:`Cancelled` if the stream was stopped (call it between steps)."""
        if self._stream.cancelled:
            raise Cancelled("the stream was stopped")

    def info(self, info: StreamInfo) -> None:
        """Say what the reader knows before the first frame."""
        self._put(info)

    def emit(self, chunk: Chunk) -> None:
        """Hand over the next chunk; waits while the queue is full (back-pressure)."""
        self._put(chunk)
        self._stream.made += 1

    def _put(self, item: object) -> None:
        while True:
            self.check()
            try:
                self._stream._queue.put(item, timeout=_POLL)
                return
            except queue.Full:
                continue


class Stream:
    """An utterance made by ``produce`` in a thread and read here in order.

    ``produce(emitter)`` calls :meth:`Emitter.info` once, then :meth:`Emitter.emit` for each
    chunk, and returns the utterance's result (:attr:`result`, once the stream is read to
    its end). An error it raises is raised to the reader, after the chunks before it.

    Use it as a context manager (leaving it early cancels it, and waits for the producer to
    unwind) and iterate it::

        with stream:
            info = stream.info()
            for chunk in stream:
                ...
        stream.result

    Parameters
    ----------
    produce : callable
        The engine's work, run in the stream's thread.
    maxsize : int
        The queue's size in chunks (:data:`QUEUE_CHUNKS`).
    name : str
        The thread's name (logs).
    """

    def __init__(
        self, produce: Callable[[Emitter], Any], *, maxsize: int = QUEUE_CHUNKS, name: str = "say"
    ) -> None:
        self._produce = produce
        self._queue: queue.Queue = queue.Queue(maxsize)
        self._stop = threading.Event()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"miketalk-{name}", daemon=True)
        self._info: StreamInfo | None = None
        self._error: BaseException | None = None
        self._ended = False
        self._adopted: list[subprocess.Popen] = []
        self._lock = threading.Lock()
        self.result: Any = None
        #: Chunks handed over so far (at most ``maxsize`` more than were read).
        self.made = 0

    # -- the producer's thread -------------------------------------------------------------
    def _run(self) -> None:
        try:
            self.result = self._produce(Emitter(self))
        except BaseException as err:  # handed to the reader, who raises it
            self._error = err
        finally:
            self._done.set()
            while not self._stop.is_set():  # the end, once the reader has room for it
                try:
                    self._queue.put(_END, timeout=_POLL)
                    break
                except queue.Full:
                    continue

    # -- the reader's side ------------------------------------------------------------------
    def start(self) -> Stream:
        """Start the producer (iterating, :meth:`info` and entering start it too)."""
        with self._lock:
            if not self._thread.is_alive() and not self._done.is_set():
                self._thread.start()
        return self

    def __enter__(self) -> Stream:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def cancelled(self) -> bool:
        """Whether :meth:`cancel` was called."""
        return self._stop.is_set()

    def info(self) -> StreamInfo:
        """What the reader knows before the first frame (waits for the producer to say it).

        Raises
        ------
        Exception
            What the producer raised before it (a :class:`~miketalk.errors.MiketalkError`
            for bad input); :class:`Cancelled` once cancelled.
        """
        self.start()
        while self._info is None:
            item = self._get()
            if item is _END:
                self._raise_end()
                raise Cancelled("the stream ended before its first frame")
            if not isinstance(item, StreamInfo):
                raise RuntimeError("a stream's producer emitted a chunk before its info")
            self._info = item
        return self._info

    def __iter__(self) -> Iterator[Chunk]:
        self.info()
        while not self._ended:
            item = self._get()
            if item is _END:
                self._ended = True
                self._raise_end()
                return
            yield item

    def _get(self) -> object:
        while True:
            if self._stop.is_set():
                raise Cancelled("the stream was stopped")
            try:
                return self._queue.get(timeout=_POLL)
            except queue.Empty:
                continue

    def _raise_end(self) -> None:
        self._thread.join()
        if self._error is not None:
            raise self._error

    def adopt(self, proc: subprocess.Popen) -> None:
        """Kill ``proc`` too on :meth:`cancel` (a writer's ffmpeg, started by the reader)."""
        with self._lock:
            self._adopted.append(proc)
        if self._stop.is_set():
            _kill(proc.pid)

    def cancel(self) -> None:
        """Stop the work now, from any thread: every process the producer started (and their
        children) is killed, the producer stops at its next step, and a reader gets
        :class:`Cancelled`. Idempotent; nothing once the stream has ended."""
        if self._stop.is_set():
            return
        self._stop.set()
        if not self._done.is_set():
            kill_thread_children(self._thread)
        with self._lock:
            adopted = list(self._adopted)
        for proc in adopted:
            if proc.poll() is None:
                _kill(proc.pid)

    def close(self) -> None:
        """Cancel the stream unless it was read to its end, and wait for its producer to
        unwind (it removes its scratch files, reaps its processes)."""
        if not self._ended:
            self.cancel()
        if self._thread.is_alive():
            self._thread.join(_JOIN)
            if self._thread.is_alive():
                log.warning("the stream's producer did not stop within %.0f s", _JOIN)
        release_free_memory()  # the engine's working memory, freed, back to the system

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the producer to end (after :meth:`cancel`); whether it did."""
        return self._done.wait(timeout)


def release_free_memory() -> bool:
    """Give the C allocator's free memory back to the system (glibc's ``malloc_trim(0)``);
    whether it could (False where the C library has none, e.g. musl or macOS).

    An utterance's drawing frees its frames, flows and sentences as it goes, but glibc keeps
    what it freed in its arenas (their free pages stay resident: a long-lived server would
    hold the largest job's working memory for good). Measured in one process after the
    stream of 24 minutes of speech on s1: 206 MB resident, 12 MB of it in use in glibc's
    arenas and 55 MB free in them; 154 MB after this (docs/serve.md, "An hour's text").
    """
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True


@functools.cache
def _malloc_trim() -> Any:
    """glibc's ``malloc_trim``, looked up once (None: the C library has none)."""
    import ctypes
    import ctypes.util

    try:
        trim = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def kill_thread_children(thread: threading.Thread) -> None:
    """SIGKILL every process ``thread`` started, and every process under them.

    A child belongs to the thread that forked it (``/proc/<pid>/task/<tid>/children``), so
    this reaches a helper thread's own children (the Festival of the sentence spoken ahead)
    and no other job's in the same process (the page's server runs several)."""
    native = thread.native_id
    if native is not None and thread.is_alive():
        for pid in _children(f"/proc/{os.getpid()}/task/{native}/children"):
            _kill_tree(pid)


def _children(path: str) -> list[int]:
    """The pids a ``/proc/.../children`` file lists (none where there is no such file)."""
    try:
        return [int(p) for p in Path(path).read_text().split()]
    except (OSError, ValueError):
        return []


def _kill_tree(pid: int) -> None:
    """SIGKILL ``pid`` and every process under it (children of any of its threads)."""
    tasks = Path(f"/proc/{pid}/task")
    below: list[int] = []
    with contextlib.suppress(OSError):
        for task in tasks.iterdir():
            below += _children(str(task / "children"))
    _kill(pid)  # first, so that it starts no more
    for child in below:
        _kill_tree(child)


def _kill(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.kill(pid, signal.SIGKILL)
