"""Atomic file output: a file (or a set of files) appears complete under its final name, or
not at all, and an older version survives any failure.

Temporary files live beside their final names (so the rename is atomic) and
are named ``.<name>.miketalk-<pid>.<start>.<random><suffix>``: hidden, and
tagged with their owner (:mod:`miketalk.media.scratch`), so that what a
killed run left behind is recognised and removed by :func:`sweep_beside`.

:func:`atomic_paths` publishes several files together (an mp4 and its timeline
JSON) as one unit. They are all written under temporary names first; then, holding
the lock of the first name (:func:`output_lock`: another process publishing the same
output waits), with the catchable signals held back:

1. ``guard()`` runs (e.g. :func:`miketalk.media.ownership.check_replaceable` again: a
   file that appeared meanwhile is not replaced);
2. a journal (``.<first name>.miketalk-<tag>.commit``) is written whole, then given its
   name: for each file its temporary name, its final name, the temporary file's inode
   and the name of a backup of the old file;
3. each old file gets its backup: a hard link (a copy where links are not possible), so
   that the old version outlives the rename;
4. the temporary files are renamed onto the final names, one by one;
5. the journal is removed (the commit point), then the backups.

A failure at any step before 5 (a rename refused, a full disk, a directory put where a
file goes) rolls the unit back in the same process (:func:`roll_back`): each final name
whose file is the new one (its inode is the journal's) gets its backup back (or is removed
when there was no old file), so the old pair is left. A run killed outright (SIGKILL, a
power cut) leaves the journal, and the next :func:`sweep_beside` beside that output finishes
the unit when every new file is still there or in place (roll forward), and rolls it back
otherwise; only then is the journal removed. Either way the old pair or the new pair,
never one of each.
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import json
import logging
import os
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from miketalk.errors import MachineFailure, MiketalkError
from miketalk.media.journal import (
    BESIDE,
    JOURNAL_FORMAT,
    JOURNAL_SUFFIX,
    MARK,
    back_up,
    recover,
    recover_beside,
    roll_back,
)
from miketalk.media.scratch import deferred_signals, owner_tag, tag_owner_alive

log = logging.getLogger(__name__)


def _check_dots(final: Path) -> None:
    """Refuse a path whose ``..`` follows a folder that does not exist (``sub/../talk.mp4``
    with no ``sub``): the system does not resolve it, and making ``sub`` to get there left
    it behind, empty."""
    prefix = Path(final.anchor)
    for part in final.parent.parts[1 if final.anchor else 0 :]:
        if part == ".." and not prefix.is_dir():
            raise MiketalkError(
                f"cannot write {final}: there is no folder {prefix} for its '..' to leave; "
                "name the folder without it"
            )
        prefix /= part


def _temporary(final: Path, suffix: str) -> Path:
    """Create an empty temporary file beside ``final`` with the usual permissions."""
    _check_dots(final)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(
            prefix=f".{final.name}.{MARK}{owner_tag()}.", suffix=suffix, dir=final.parent
        )
    except OSError as err:
        raise MiketalkError(f"cannot write {final}: {err.strerror or err}") from None
    os.close(fd)
    tmp = Path(name)
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o666 & ~umask)  # mkstemp makes 0600; give the final file the usual mode
    return tmp


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], *, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    The temporary file keeps the final suffix (so writers that pick a format
    by suffix still work). On any exception the temporary file is removed and
    ``path`` is untouched.

    Parameters
    ----------
    path : path-like
        The final file name; its directory is created if needed.
    suffix : str, optional
        Suffix of the temporary file; defaults to that of ``path``.

    Yields
    ------
    pathlib.Path
        Where to write.

    Raises
    ------
    MiketalkError
        If the directory cannot be created or written in (before anything is written).
    """
    with atomic_paths([path], suffixes=None if suffix is None else [suffix]) as (tmp,):
        yield tmp


@contextlib.contextmanager
def atomic_paths(
    paths: Sequence[str | os.PathLike[str]],
    *,
    suffixes: Sequence[str] | None = None,
    guard: Callable[[], object] | None = None,
) -> Iterator[list[Path]]:
    """Temporary paths beside ``paths`` (one directory), published onto them as one unit.

    All temporary files are created on entry, so a directory that cannot be
    written in is reported before any work. On success they replace the
    final files together (see the module docstring); on any exception they
    are removed and the final files are untouched.

    Parameters
    ----------
    paths : sequence of path-like
        The final file names, all in one directory.
    suffixes : sequence of str, optional
        Suffix of each temporary file (default: each final name's).
    guard : callable, optional
        Called with the output's lock held, just before the files are published; what it
        raises stops the publication (the old files stay).

    Yields
    ------
    list of pathlib.Path
        Where to write each file.

    Raises
    ------
    MiketalkError
        If the directory cannot be created or written in, or a file cannot be published
        (the old files are then left as they were).
    """
    finals = [Path(p) for p in paths]
    if not finals:
        raise ValueError("atomic_paths needs at least one path")
    if len({f.parent.resolve() for f in finals}) != 1:
        raise ValueError("atomic_paths replaces files of one directory only")
    suffixes = [f.suffix for f in finals] if suffixes is None else list(suffixes)
    temps: list[Path] = []
    try:
        for final, suffix in zip(finals, suffixes, strict=True):
            with deferred_signals():  # made and recorded for clean-up, or neither
                temps.append(_temporary(final, suffix))
        yield temps
        renames = list(zip(temps, finals, strict=True))
        if len(renames) == 1 and guard is None:
            # One rename is atomic by itself: no lock, and no listing of the directory for
            # journals (a frames folder's thousands of files made that quadratic in its
            # length). A killed unit's journal naming this file is settled by the next
            # unit or sweep of it, which will not undo this newer file (roll_forward).
            _commit(renames)
            return
        with output_lock(finals[0]):
            recover_beside(finals[0])  # a unit of a killed run settled first
            if guard is not None:
                guard()
            _commit(renames)
    except BaseException:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        raise


def lock_path(path: str | os.PathLike[str]) -> Path:
    """The lock file of output ``path``: ``.<name>.miketalk.lock`` beside it."""
    path = Path(path)
    return path.parent / f".{path.name}.{MARK}lock"


@contextlib.contextmanager
def output_lock(path: str | os.PathLike[str], *, wait: bool = True) -> Iterator[None]:
    """Hold the lock of output ``path`` while the body runs; wait while another process holds it
    (or, with ``wait`` False, refuse at once: a build holds its model's lock from before its
    work to its end).

    ``fcntl.flock`` on :func:`lock_path`; the file is removed on release (a process that
    was waiting for it then finds the file it locked gone and locks the new one), so no
    lock file is left beside the output. Waiting can be interrupted by Ctrl-C or SIGTERM.

    Raises
    ------
    MiketalkError
        If the lock file cannot be made (a directory that cannot be written in), or, with
        ``wait`` False, another process holds the lock.
    """
    import fcntl

    lock = lock_path(path)
    waited = False
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as err:
            raise MiketalkError(f"cannot write {path}: {err.strerror or err}") from None
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                if not wait:
                    raise MiketalkError(
                        f"another miketalk is writing {path} now: wait for it to end, or give "
                        "another -o"
                    ) from None
                if not waited:
                    log.warning("waiting for another miketalk that is writing %s", path)
                    waited = True
                fcntl.flock(fd, fcntl.LOCK_EX)
            held = os.fstat(fd)
            try:
                now = os.stat(lock)
            except FileNotFoundError:
                now = None
        except BaseException:
            os.close(fd)
            raise
        if now is not None and (now.st_dev, now.st_ino) == (held.st_dev, held.st_ino):
            break
        os.close(fd)  # the holder we waited for removed it: lock the new one
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock)
        os.close(fd)


def check_writable(path: str | os.PathLike[str]) -> None:
    """Check that a file can be written at ``path``: make (and remove) a temporary file beside it.

    The folders it makes for the check are removed again when still empty (the writers
    make them when they write): a run refused after the check leaves no empty folder.

    Raises
    ------
    MiketalkError
        If the directory cannot be created or written in (read-only, not a
        directory, no space...), naming the file.
    """
    path = Path(path)
    made = list(itertools.takewhile(lambda p: not p.exists(), path.absolute().parents))
    with deferred_signals():
        try:
            _temporary(path, ".probe").unlink()
        finally:
            for folder in made:  # the deepest first
                try:
                    folder.rmdir()
                except OSError:  # not made here, or no longer empty
                    break


def _commit(renames: list[tuple[Path, Path]]) -> None:
    """Publish each temporary file onto its final name, all or none (module docstring)."""
    if len(renames) == 1:
        try:
            os.replace(*renames[0])
        except OSError as err:
            kind = MachineFailure if err.errno in MACHINE_ERRNOS else MiketalkError
            raise kind(
                f"cannot write {renames[0][1]}: {err.strerror or err}; it was left as it was"
            ) from None
        return
    first = renames[0][1]
    journal = first.parent / f".{first.name}.{MARK}{owner_tag()}{JOURNAL_SUFFIX}"
    entries = [
        {
            "temporary": tmp.name,
            "final": final.name,
            "inode": os.stat(tmp).st_ino,
            "backup": f".{final.name}.{MARK}{owner_tag()}.{os.urandom(4).hex()}.old",
        }
        for tmp, final in renames
    ]
    with deferred_signals():
        staging = _temporary(journal, ".journal")
        try:
            staging.write_text(json.dumps({"format": JOURNAL_FORMAT, "files": entries}))
            os.replace(staging, journal)
        except BaseException:
            staging.unlink(missing_ok=True)
            raise
        try:
            for entry in entries:
                back_up(first.parent, entry)
            for tmp, final in renames:
                os.replace(tmp, final)
        except BaseException as err:
            roll_back(journal)
            if isinstance(err, OSError):
                where = err.filename or first
                kind = MachineFailure if err.errno in MACHINE_ERRNOS else MiketalkError
                raise kind(
                    f"cannot write {where}: {err.strerror or err}; the old "
                    f"{' and '.join(f.name for _, f in renames)} were left as they were"
                ) from None
            raise
        journal.unlink()
        for entry in entries:
            (first.parent / entry["backup"]).unlink(missing_ok=True)


#: What an OSError of the machine (not of the user's choice of output) is: a full disk, a
#: quota, an input/output error.
MACHINE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EIO})


def sweep_beside(path: str | os.PathLike[str]) -> list[Path]:
    """Tidy what killed runs left in ``path``'s directory; return the files removed.

    An unfinished unit (a journal whose owner is gone) is settled first, under its
    output's lock: finished when all its new files are there, else rolled back, so a set
    of files written together is never left half replaced; then every temporary file
    whose owner is gone is removed. Files of running processes and files without
    miketalk's tag are left alone.
    """
    directory = Path(path).parent
    try:
        names = sorted(os.listdir(directory))
    except OSError:
        return []
    stale = []
    for name in names:
        match = BESIDE.match(name)
        if match is not None and not tag_owner_alive(match["tag"]):
            stale.append((name, match))
    removed = []
    for name, match in stale:
        if "." + match["rest"] == JOURNAL_SUFFIX:
            journal = directory / name
            with output_lock(directory / match["name"]):
                if journal.exists():
                    recover(journal)
            if not journal.exists():
                removed.append(journal)
    for name, _ in stale:
        victim = directory / name
        if victim.is_file() and not victim.is_symlink():
            victim.unlink(missing_ok=True)
            removed.append(victim)
            log.info("removed %s, left by a run that was killed", victim)
    return removed


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    write_bytes_atomic(path, text.encode("utf-8"))
