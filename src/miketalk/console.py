"""What the command line needs around its work: clean standard streams and signals.

``stdout`` carries the result only (``miketalk phones --json | jq`` must parse).
Libraries print behind the command's back: OpenEXR's Python module writes
``Warning: ...`` lines on ``sys.stdout`` and its C library error details on
descriptor 2, OpenCV and libpng on descriptor 2. :func:`native_output_logged`
points descriptors 1 and 2 at a pipe for the duration of a command (so
``sys.stdout``, which writes on descriptor 1, goes there too), gives
``sys.stderr`` the real stderr, hands the command the real stdout for its
result, and turns every line that comes through the pipe into a warning of
the ``miketalk.native`` logger (on stderr).

:func:`handle_termination` makes SIGTERM and SIGHUP behave like Ctrl-C: they
raise :class:`Terminated` (a :class:`KeyboardInterrupt`), so every clean-up
that runs on Ctrl-C (the Festival run, the scratch directories, temporary
files) runs on them too. A signal that lands inside a ``__del__`` method is
raised again once that method has finished, since Python would print and
drop an exception raised there. Inside :func:`signals_held` (the few statements
between making a temporary file and recording it for clean-up) the signal,
Ctrl-C included, is held and raised when the block ends: blocking it with
``pthread_sigmask`` alone is not enough, since the kernel then hands it to
another thread and Python still runs the handler in the main thread at once.

The exception stops the main thread only: work in other threads (a thread pool's
clips being decoded) runs on, and the pool's shutdown waits for it. So a signal
that stops the run first kills, in its handler, every process started through
:func:`child_process` (the ffmpeg decoders of :mod:`miketalk.media.decode`): the
threads waiting for them return at once. Until the block ends
(:func:`stopping`), no thread but the main one starts another: the queued clips
fail at once instead of being decoded.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import logging
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import FrameType
from typing import IO, TextIO

native_log = logging.getLogger("miketalk.native")


class Terminated(KeyboardInterrupt):
    """The process was asked to stop by a signal (SIGTERM, SIGHUP); ``signum`` says which."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


#: Signals held by :func:`signals_held` (the main thread's), raised when it ends.
_held: list[int] = []
_holding = [0]


#: The child processes of :func:`child_process` running now: a stop kills them.
_children: set[subprocess.Popen] = set()
#: Whether a signal has stopped the run of the current :func:`handle_termination` block.
_stopped = [False]


def stopping() -> bool:
    """Whether a signal has stopped the run (inside :func:`handle_termination`).

    False again once the :func:`handle_termination` block ends.
    """
    return _stopped[0]


@contextlib.contextmanager
def child_process(
    args: Sequence[str], *, stderr: int | IO[bytes] | None = subprocess.PIPE
) -> Iterator[subprocess.Popen]:
    """A child process that a signal stopping the run kills at once (module docstring).

    Started with ``args`` (no shell), no standard input, its stdout a pipe; killed if
    the body raises; its pipes closed and the process waited for on leaving.

    Parameters
    ----------
    args : sequence of str
        The program and its arguments.
    stderr : int or file, optional
        Where its stderr goes (default: a pipe).

    Raises
    ------
    MiketalkError
        In a thread other than the main one once the run is stopping: nothing is
        started (the main thread is stopped by the signal's exception).
    """
    from miketalk.errors import MiketalkError

    def refused() -> bool:
        return _stopped[0] and threading.current_thread() is not threading.main_thread()

    if refused():
        raise MiketalkError(f"{Path(args[0]).name} not started: the run is stopping")
    proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=stderr)
    _children.add(proc)
    try:
        if refused():  # the stop came while it started, and did not see it
            proc.kill()
        with proc:
            try:
                yield proc
            except BaseException:
                proc.kill()
                raise
    finally:
        _children.discard(proc)


def _stop() -> None:
    """Mark the run stopped and kill the children of :func:`child_process` (in a
    signal's handler: no lock is taken)."""
    _stopped[0] = True
    for proc in list(_children):
        with contextlib.suppress(OSError):
            proc.kill()


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold the signals :func:`handle_termination` handles until the body has run.

    A held signal is raised (as :class:`Terminated`, or :class:`KeyboardInterrupt`
    for Ctrl-C) when the outermost block ends. Nests; elsewhere than in the main
    thread the body just runs.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _holding[0] += 1
    try:
        yield
    finally:
        _holding[0] -= 1
        if _holding[0] == 0 and _held:
            signum = _held[0]
            _held.clear()
            if signum == signal.SIGINT:
                raise KeyboardInterrupt
            raise Terminated(signum)


@contextlib.contextmanager
def handle_termination() -> Iterator[None]:
    """Raise :class:`Terminated` on SIGTERM and SIGHUP while the body runs (main thread only).

    A second signal while the first one's clean-up runs is ignored, so the
    clean-up is not itself cut short. A signal that stops the run (Ctrl-C too, when
    Python's own handler has it) first kills the children of :func:`child_process`.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    names = ("SIGTERM", "SIGHUP")
    numbers = [getattr(signal, n) for n in names if hasattr(signal, n)]
    fired = []

    def handler(signum: int, frame: FrameType | None) -> None:
        if fired:
            return
        if _holding[0]:
            _stop()
            _held.append(signum)
            fired.append(signum)
            return
        if _in_finalizer(frame):
            # an exception raised in __del__ is printed and lost ("Exception ignored
            # in ..."): ask again once the finalizer is done
            threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
            return
        _stop()
        fired.append(signum)
        raise Terminated(signum)

    def interrupt(signum: int, frame: FrameType | None) -> None:
        if _in_finalizer(frame):
            # raised there, Ctrl-C would be printed and lost and the run would go on:
            # ask again once the finalizer is done
            threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
            return
        _stop()
        if _holding[0]:
            if not _held:
                _held.append(signum)
            return
        signal.default_int_handler(signum, frame)

    old = {n: signal.signal(n, handler) for n in numbers}
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        old[signal.SIGINT] = signal.signal(signal.SIGINT, interrupt)
    try:
        yield
    finally:
        for n, previous in old.items():
            signal.signal(n, previous)
        _stopped[0] = False


#: The code of the callbacks ``os.fork`` runs around a fork in the parent (logging's lock,
#: taken before and given back after; Python 3.11 names): an exception raised in them is
#: printed and lost, as in a ``__del__``. Called elsewhere, a signal there only waits 10 ms.
_FORK_CALLBACKS = frozenset(
    function.__code__
    for name in ("_acquireLock", "_releaseLock", "_prepareFork", "_afterFork")
    if callable(function := getattr(logging, name, None)) and hasattr(function, "__code__")
)


def _in_finalizer(frame: FrameType | None) -> bool:
    """Whether ``frame`` runs where an exception would be printed and lost: inside a
    ``__del__`` method, or a callback ``os.fork`` runs (:data:`_FORK_CALLBACKS`)."""
    while frame is not None:
        if frame.f_code.co_name == "__del__" or frame.f_code in _FORK_CALLBACKS:
            return True
        frame = frame.f_back
    return False


def _real_fileno(stream: object) -> int | None:
    try:
        return stream.fileno()  # type: ignore[attr-defined]
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        return None


@contextlib.contextmanager
def native_output_logged() -> Iterator[TextIO]:
    """Route what libraries print on stdout and stderr to logging (see the module docstring).

    Yields
    ------
    TextIO
        The real stdout: where the command writes its result. Logging and
        ``sys.stderr`` keep writing to the real stderr. When ``sys.stdout`` or
        ``sys.stderr`` is not a real file (a test capturing them), nothing is
        redirected and ``sys.stdout`` is yielded.
    """
    out_fd, err_fd = _real_fileno(sys.stdout), _real_fileno(sys.stderr)
    if out_fd != 1 or err_fd != 2:
        yield sys.stdout
        return
    sys.stdout.flush()
    sys.stderr.flush()
    keep_out, keep_err = os.dup(1), os.dup(2)
    read_end, write_end = os.pipe()
    os.dup2(write_end, 1)
    os.dup2(write_end, 2)
    os.close(write_end)
    old_out, old_err = sys.stdout, sys.stderr
    result = io.TextIOWrapper(
        io.FileIO(keep_out, "w", closefd=False),
        encoding=old_out.encoding or "utf-8",
        line_buffering=True,
    )
    sys.stderr = io.TextIOWrapper(
        io.FileIO(keep_err, "w", closefd=False),
        encoding=old_err.encoding or "utf-8",
        errors="backslashreplace",
        line_buffering=True,
    )
    handlers = [h for h in logging.getLogger().handlers if isinstance(h, logging.StreamHandler)]
    retarget = [h for h in handlers if getattr(h, "stream", None) is old_err]
    for h in retarget:
        h.setStream(sys.stderr)
    reader = threading.Thread(target=_relay, args=(read_end,), name="miketalk-native", daemon=True)
    reader.start()
    try:
        yield result
    finally:
        with contextlib.suppress(Exception):
            result.flush()
            sys.stdout.flush()
            sys.stderr.flush()
        _flush_c_stdio()  # what native code left in the C library's buffers goes to the pipe
        os.dup2(keep_out, 1)
        os.dup2(keep_err, 2)
        reader.join(timeout=5.0)  # its last lines logged before the command's own last line
        for h in retarget:
            h.setStream(old_err)
        sys.stderr = old_err
        os.close(keep_out)
        os.close(keep_err)


def _flush_c_stdio() -> None:
    """``fflush(NULL)``: the C library's stdout buffer (where C++'s ``std::cout`` writes)."""
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


def _relay(fd: int) -> None:
    """Log each line read from ``fd`` until its end (the thread of native_output_logged)."""
    with open(fd, "rb") as pipe:
        for raw in pipe:
            line = raw.decode("utf-8", "replace").rstrip()
            if line:
                native_log.warning("%s", line)
