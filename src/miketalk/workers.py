"""Worker processes: how many a command may start, and a pool that ends them all when stopped.

:func:`check_workers` refuses a worker count outside 1 to the machine's cores (the cores
this process may run on) in one line, before any work. :func:`process_pool` is a
:class:`~concurrent.futures.ProcessPoolExecutor` whose workers ignore Ctrl-C (the parent
decides), die with their parent (``PR_SET_PDEATHSIG``: a parent killed outright leaves no
orphans), and are ended within a second when the body raises (Ctrl-C, SIGTERM, an error):
the queued work is cancelled and every worker terminated, then killed, instead of the
executor's default of finishing all that was queued.

A worker forked from this process inherits its Python signal handlers (SIGTERM raising
:class:`~miketalk.console.Terminated`) until its start-up replaces them: a SIGTERM in
between (the pool stopped while it starts) printed tracebacks from the worker. The workers
are therefore started with the stopping signals blocked, and unblock them once their own
handlers are set: a signal that came meanwhile then ends the worker at once, silently.

Python runs a signal's handler in the main thread between two bytecodes. A main thread
waiting on a lock with no time limit (``future.result()``, ``Executor.map``) is woken by
a signal only if the signal lands while it waits: one that lands just before the wait
begins (its handler's flag set, the wait not yet entered) is seen only when the wait
ends, so a SIGTERM sent as the main thread starts waiting on a worker's long job was
lost until that job ended. :func:`results` and :func:`map_in_pool` wait in slices of
0.1 s: the handler runs within a slice.
"""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor, wait

from miketalk.errors import MachineFailure, MiketalkError

__all__ = [
    "InChild",
    "available_cores",
    "check_workers",
    "default_workers",
    "map_in_pool",
    "process_pool",
    "results",
    "run_in_child",
    "stop_pool",
]


#: Threads a model's frames are drawn in (:meth:`miketalk.model.morphs.Morphs.render`,
#: :func:`miketalk.draw.learned.render_learned`): the machine's cores, at most 2 (the third
#: core's worth of work, encoding the video, runs in ffmpeg beside them).
RENDER_WORKERS = max(1, min(2, os.cpu_count() or 1))


def available_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_workers() -> int:
    """Two workers, or one on a machine of one core."""
    return min(2, available_cores())


def one_blas_thread() -> contextlib.AbstractContextManager:
    """Hold the BLAS libraries loaded (numpy's OpenBLAS) to one thread, inside a ``with``.

    miketalk parallelizes with its own workers, so a BLAS library's threads only compete
    with them for the cores; and OpenBLAS's threads wait for work by spinning. The learned
    coarticulation's fit (many small products of a tall Jacobian) took 132 s of wall and
    CPU time with OpenBLAS's two threads while one other process ran on this 2-core
    machine, and 10.3 s with one.
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def check_workers(workers: object, *, option: str = "--workers") -> int:
    """``workers`` as an int from 1 to :func:`available_cores`.

    Raises
    ------
    MiketalkError
        In one line, for anything else.
    """
    cores = available_cores()
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= cores:
        raise MiketalkError(
            f"{option} must be a whole number from 1 to {cores} (this machine's cores), "
            f"not {workers!r}"
        )
    return workers


def _prctl(option: int, argument: object) -> None:
    """Linux's ``prctl(option, argument)`` for this process; elsewhere nothing."""
    with contextlib.suppress(Exception):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(option, argument)


def _die_with_parent() -> None:
    """Ask the kernel to kill this process when its parent dies (``PR_SET_PDEATHSIG``)."""
    _prctl(1, signal.SIGKILL)


def _name_process(name: str) -> None:
    """Give this process ``name`` (its first 15 bytes) in ``ps``, ``top`` and
    ``/proc/PID/comm`` (``PR_SET_NAME``)."""
    _prctl(15, name.encode()[:15] + b"\0")


#: The signals that stop a run (:func:`miketalk.console.handle_termination`).
_STOPPING = {getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)}


@contextlib.contextmanager
def _stopping_signals_blocked() -> Iterator[None]:
    """Block the stopping signals in this thread while the body runs: the processes it
    forks start with them blocked (the module docstring). Where ``pthread_sigmask`` is
    missing, nothing is blocked."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _STOPPING)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _start_worker(initializer: Callable[..., object] | None, initargs: tuple, parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the
    for name in ("SIGTERM", "SIGHUP"):  # parent stops the workers itself
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):  # started with them blocked: a SIGTERM that
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOPPING)  # came meanwhile ends it now
    _die_with_parent()
    if os.getppid() != parent:  # the parent died before the kernel was asked
        os._exit(1)
    if initializer is not None:
        initializer(*initargs)


def stop_pool(pool: ProcessPoolExecutor, *, grace: float = 1.0) -> None:
    """Cancel what ``pool`` has queued and end its workers: SIGTERM, then SIGKILL after
    ``grace`` seconds."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        with contextlib.suppress(Exception):
            process.terminate()
    deadline = time.monotonic() + grace
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(max(0.0, deadline - time.monotonic()))
    for process in processes:
        with contextlib.suppress(Exception):
            if process.is_alive():
                process.kill()
                process.join(0.5)
    # the executor's thread, finding its workers gone, closes the pool's pipes: waited for,
    # so that the interpreter's exit does not write to one it is closing (a traceback)
    manager = getattr(pool, "_executor_manager_thread", None)
    if manager is not None:
        manager.join(max(0.1, deadline + 0.5 - time.monotonic()))


@contextlib.contextmanager
def process_pool(
    workers: int,
    *,
    initializer: Callable[..., object] | None = None,
    initargs: tuple = (),
) -> Iterator[ProcessPoolExecutor]:
    """A process pool of ``workers`` (see the module docstring).

    On leaving normally the pool is shut down as usual (waiting for its work); on an
    exception (:class:`KeyboardInterrupt` and the SIGTERM of
    :func:`miketalk.console.handle_termination` included) :func:`stop_pool` ends it.
    """
    pool = ProcessPoolExecutor(
        max_workers=workers,
        initializer=_start_worker,
        initargs=(initializer, initargs, os.getpid()),
    )
    try:
        with _stopping_signals_blocked():  # forked now (all of them at the first submit),
            pool.submit(int)  # with the stopping signals blocked: the module docstring
        yield pool
    except BaseException:
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def results(futures: Iterable[Future], *, poll: float = 0.1) -> Iterator[object]:
    """Each future's result, in order, waited for in slices of ``poll`` seconds.

    Instead of ``future.result()`` in the main thread: a stopping signal's handler runs
    within a slice (the module docstring). On leaving early (an exception, the consumer
    gone) the futures not yet waited for are cancelled (those not yet running).
    """
    futures = list(futures)
    waited = 0
    try:
        for future in futures:
            while not wait([future], timeout=poll).done:
                pass
            waited += 1
            yield future.result()
    finally:
        for future in futures[waited:]:
            future.cancel()


def map_in_pool(
    pool: Executor, function: Callable[..., object], items: Iterable, *, chunksize: int = 1
) -> Iterator[object]:
    """``pool.map(function, items, chunksize=chunksize)``, its results waited for by
    :func:`results` (``Executor.map`` waits with no time limit)."""
    items = list(items)
    chunks = [items[i : i + chunksize] for i in range(0, len(items), max(1, chunksize))]
    for chunk in results(pool.submit(_each, function, chunk) for chunk in chunks):
        yield from chunk  # type: ignore[misc]


def _each(function: Callable[..., object], chunk: list) -> list:
    """``function`` of each item of ``chunk`` (a worker's job of :func:`map_in_pool`)."""
    return [function(item) for item in chunk]


def run_in_child(function: Callable[..., object], *args: object) -> object:
    """``function(*args)`` in a forked child process; its result (or its exception) here.

    For work in native code that holds the interpreter (the forced aligner: minutes of
    audio in one call), during which a signal's handler cannot run: the parent waits on a
    pipe (in slices of 0.1 s: the module docstring), so Ctrl-C or SIGTERM stops the wait at
    once, and the child is killed with it. The child dies with its parent, also when the
    parent is killed outright; ``ps`` names it ``mt:`` and the function's name. From
    another thread (an utterance's stream, :mod:`miketalk.talk.stream`) the child is forked
    the same way: the thread waits on the pipe without holding the interpreter, so the main
    thread still handles a signal, and the stream's stop kills the child. Where ``fork`` is
    missing, or this process is itself such a child (:class:`InChild`'s: the default
    action of Ctrl-C and SIGTERM ends it at once, and its parent kills it), the function
    runs here: a dub's alignment keeps the aligner it loaded (1 s of CPU) for the text's
    guided pass instead of loading it again in a grandchild.

    Raises
    ------
    BaseException
        What ``function`` raised (it must pickle: :class:`~miketalk.errors.MiketalkError`
        does), or the parent's :class:`KeyboardInterrupt`.
    """
    if _forked_child:
        return function(*args)
    return InChild(function, *args).result()


class InChild:
    """``function(*args)`` started now in a forked child process (as :func:`run_in_child`
    runs it), its result asked for later: the caller works on meanwhile, on another core.

    :meth:`result` waits for it (once); leaving the ``with`` block, or :meth:`cancel`,
    kills a child whose result was not taken. Where ``fork`` is missing, the function runs
    in :meth:`result`.
    """

    def __init__(self, function: Callable[..., object], *args: object) -> None:
        self._call = (function, args)
        self._pid: int | None = None
        self._read_end = -1
        if hasattr(os, "fork"):
            self._read_end, self._pid = _forked(function, args)

    def __enter__(self) -> InChild:
        return self

    def __exit__(self, *exc: object) -> None:
        self.cancel()

    def cancel(self) -> None:
        """Kill the child and reap it, unless its result was taken."""
        if self._pid is None:
            return
        pid, self._pid = self._pid, None
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        os.close(self._read_end)

    def result(self) -> object:
        """The function's result, waited for (:func:`run_in_child`).

        Raises
        ------
        BaseException
            What the function raised, or the waiting thread's :class:`KeyboardInterrupt`.
        """
        import pickle
        import select

        if self._pid is None and self._read_end < 0:
            function, args = self._call
            return function(*args)
        if self._pid is None:
            raise MiketalkError("the child's result was taken, or the child was cancelled")
        pid = self._pid
        chunks = []
        try:
            with os.fdopen(self._read_end, "rb", closefd=False) as pipe:
                while True:  # a signal's handler runs during the wait (in slices), may raise
                    if not select.select([pipe], [], [], 0.1)[0]:
                        continue
                    block = os.read(pipe.fileno(), 1 << 20)
                    if not block:
                        break
                    chunks.append(block)
        except BaseException:
            self.cancel()
            raise
        self._pid = None
        os.close(self._read_end)
        _, status = os.waitpid(pid, 0)
        if not chunks:
            raise MachineFailure(
                "the worker process ended without a result (status "
                f"{os.waitstatus_to_exitcode(status)}): killed when memory ran out?"
            )
        ok, value = pickle.loads(b"".join(chunks))
        if not ok:
            raise value
        return value


#: True in a child forked by :func:`_forked` (its stopping signals' default actions kill it).
_forked_child = False


def _forked(function: Callable[..., object], args: tuple) -> tuple[int, int]:
    """Fork a child that runs ``function(*args)`` and writes its pickled outcome on a pipe:
    the pipe's read end and the child's pid."""
    import pickle

    read_end, write_end = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the child: no Python handler for the signals, no way back
        global _forked_child
        _forked_child = True
        code = 0
        try:
            os.close(read_end)
            for signum in (signal.SIGINT, signal.SIGTERM):
                signal.signal(signum, signal.SIG_DFL)
            _die_with_parent()
            _name_process("mt:" + getattr(function, "func", function).__name__)
            if os.getppid() != parent:
                os._exit(1)
            try:
                outcome = (True, function(*args))
            except BaseException as err:  # handed to the parent, which raises it
                outcome = (False, err)
            try:
                data = pickle.dumps(outcome)
            except Exception as err:  # an exception that does not pickle: its text
                data = pickle.dumps((False, MiketalkError(f"{type(err).__name__}: {err}")))
            with os.fdopen(write_end, "wb") as pipe:
                pipe.write(data)
        except BaseException:
            code = 1
        finally:
            os._exit(code)
    os.close(write_end)
    return read_end, pid
