"""Scratch files that name their owner, so that what a killed run left behind can be removed.

A run cleans up after itself on errors, Ctrl-C and SIGTERM; only SIGKILL (or a
power cut) leaves its scratch behind. So every scratch directory in the
temporary directory and every temporary file beside an output carries its
owner's *tag*: the process id and the process's start time (in clock ticks
since boot, from ``/proc/<pid>/stat``). The pair identifies one process even
when the id is later reused, so "the owner is gone" is decided exactly:
:func:`owner_alive` is false only when no process with that id and that start
time exists. :func:`sweep_scratch` removes such leftovers from the temporary
directory; :func:`miketalk.media.atomic.sweep_beside` does the same beside an
output. Names without a tag (made by other programs, or by miketalk before the
tag) are never touched.

A scratch directory is removed by :func:`remove_tree`: its files unlinked by several
threads at once. Where the file system discards freed blocks as it goes (``mount -o
discard``, as on this project's machines), an unlink waits for the disk: ``rm -rf`` of a
build's work folder of 668 files (30 s of video, the corpus's frames) took 1.6 to 2.6 s
at a load of 15, most of a stopped build's time to exit; 4 to 32 threads took 0.05 to
0.13 s.

Only the standard library is used: Festival is started before numpy loads.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import shutil
import signal
import tempfile
from collections.abc import Iterator
from functools import cache
from pathlib import Path

from miketalk.console import signals_held

log = logging.getLogger(__name__)

#: ``<kind>-<pid>.<start>-`` after the ``miketalk-`` prefix of a scratch directory.
_SCRATCH = re.compile(r"^miketalk-(?P<kind>[a-z0-9]+)-(?P<pid>\d+)\.(?P<start>\d+)-[^/]+$")


def _start_time(pid: int) -> int | None:
    """The start time of process ``pid`` in clock ticks since boot; None if there is none.

    On systems without ``/proc`` a live process has start time 0.
    """
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return None
    except OSError:  # no /proc (not Linux): fall back to whether the id is in use
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return None
        except PermissionError:
            return 0
        return 0
    # the command name (field 2) is in parentheses and may hold spaces: split after it
    fields = stat[stat.rindex(")") + 2 :].split()
    return int(fields[19])  # field 22 of the whole line


@cache
def _own_tag(pid: int) -> str:
    start = _start_time(pid)
    return f"{pid}.{start if start is not None else 0}"


def owner_tag() -> str:
    """``<pid>.<start time>`` of this process (what scratch names carry)."""
    return _own_tag(os.getpid())


def owner_alive(pid: int, start: int) -> bool:
    """Whether the process that made a scratch name tagged ``<pid>.<start>`` still runs."""
    now = _start_time(pid)
    return now is not None and (now == start or now == 0 or start == 0)


def tag_owner_alive(tag: str) -> bool:
    """:func:`owner_alive` of a ``<pid>.<start>`` tag (a malformed tag counts as alive)."""
    try:
        pid, start = (int(x) for x in tag.split("."))
    except ValueError:
        return True
    return owner_alive(pid, start)


#: The signals a run turns into exceptions (Ctrl-C, SIGTERM, SIGHUP).
CAUGHT_SIGNALS = tuple(
    s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s is not None
)


@contextlib.contextmanager
def deferred_signals() -> Iterator[None]:
    """Hold back Ctrl-C, SIGTERM and SIGHUP while the body runs; they arrive after it.

    For the few statements between creating a file and recording it for
    clean-up: an exception raised between the two would leave the file behind.
    """
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, CAUGHT_SIGNALS)
    try:
        with signals_held():  # another thread may take the signal: the handler holds it too
            yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


@contextlib.contextmanager
def scratch_dir(kind: str, *, directory: str | os.PathLike[str] | None = None) -> Iterator[Path]:
    """A private directory in the temporary directory, removed on leaving (whatever happened).

    Named ``miketalk-<kind>-<pid>.<start>-XXXX``; leftovers of runs that were
    killed are swept first (:func:`sweep_scratch`).

    Parameters
    ----------
    kind : str
        Lower-case letters and digits: what the directory is for (``festival``, ``mp4``).
    directory : path-like, optional
        Where to make it (default: the temporary directory); e.g. beside an output that
        is renamed out of it at the end (one file system).
    """
    if not re.fullmatch(r"[a-z0-9]+", kind):
        raise ValueError(f"scratch kind must be lower-case letters and digits, not {kind!r}")
    sweep_scratch(directory)
    with contextlib.ExitStack() as stack:
        with deferred_signals():
            path = Path(tempfile.mkdtemp(prefix=f"miketalk-{kind}-{owner_tag()}-", dir=directory))
            stack.callback(remove_tree, path)
        yield path


#: Threads unlinking a directory's files at once (:func:`remove_tree`).
REMOVAL_THREADS = 16


def remove_tree(path: str | os.PathLike[str]) -> None:
    """Remove the directory ``path`` and all it holds, as ``shutil.rmtree(path,
    ignore_errors=True)`` does (symbolic links removed, never followed), its files unlinked
    by :data:`REMOVAL_THREADS` threads at once (the module docstring)."""
    files: list[str] = []
    for root, dirs, names in os.walk(path):
        files.extend(os.path.join(root, n) for n in names)
        files.extend(os.path.join(root, d) for d in dirs if os.path.islink(os.path.join(root, d)))
    if len(files) > 2 * REMOVAL_THREADS:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(REMOVAL_THREADS, thread_name_prefix="miketalk-rm") as pool:
            for _ in pool.map(_unlink, files):
                pass
    shutil.rmtree(path, ignore_errors=True)  # the folders, and the few files left


def _unlink(file: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(file)


def sweep_scratch(directory: str | os.PathLike[str] | None = None) -> list[Path]:
    """Remove the scratch directories whose owner is gone; return what was removed.

    Parameters
    ----------
    directory : path-like, optional
        Where to look (default: the temporary directory, ``$TMPDIR``).
    """
    root = Path(directory) if directory is not None else Path(tempfile.gettempdir())
    removed = []
    try:
        names = os.listdir(root)
    except OSError:
        return removed
    for name in names:
        match = _SCRATCH.match(name)
        if match is None:
            continue
        if owner_alive(int(match["pid"]), int(match["start"])):
            continue
        path = root / name
        if path.is_dir() and not path.is_symlink():
            remove_tree(path)
            if not path.exists():
                removed.append(path)
                log.info("removed %s, left by a run that was killed", path)
    return removed
