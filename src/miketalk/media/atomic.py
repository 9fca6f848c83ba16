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
import json
import logging
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from miketalk.errors import MachineFailure, MiketalkError
from miketalk.media.scratch import deferred_signals, owner_tag, tag_owner_alive

log = logging.getLogger(__name__)

_MARK = "miketalk-"
#: ``.<name>.miketalk-<pid>.<start>.<rest>``: a temporary file or journal of ``<name>``.
_BESIDE = re.compile(r"^\.(?P<name>.+)\.miketalk-(?P<tag>\d+\.\d+)\.(?P<rest>[^/]+)$")
_JOURNAL_SUFFIX = ".commit"


def _temporary(final: Path, suffix: str) -> Path:
    """Create an empty temporary file beside ``final`` with the usual permissions."""
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(
            prefix=f".{final.name}.{_MARK}{owner_tag()}.", suffix=suffix, dir=final.parent
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
            _recover_beside(finals[0])  # a unit of a killed run settled first
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
    return path.parent / f".{path.name}.{_MARK}lock"


@contextlib.contextmanager
def output_lock(path: str | os.PathLike[str]) -> Iterator[None]:
    """Hold the lock of output ``path`` while the body runs; wait while another process holds it.

    ``fcntl.flock`` on :func:`lock_path`; the file is removed on release (a process that
    was waiting for it then finds the file it locked gone and locks the new one), so no
    lock file is left beside the output. Waiting can be interrupted by Ctrl-C or SIGTERM.

    Raises
    ------
    MiketalkError
        If the lock file cannot be made (a directory that cannot be written in).
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

    The directory is created if needed.

    Raises
    ------
    MiketalkError
        If the directory cannot be created or written in (read-only, not a
        directory, no space...), naming the file.
    """
    with deferred_signals():
        _temporary(Path(path), ".probe").unlink()


def _commit(renames: list[tuple[Path, Path]]) -> None:
    """Publish each temporary file onto its final name, all or none (module docstring)."""
    if len(renames) == 1:
        try:
            os.replace(*renames[0])
        except OSError as err:
            kind = MachineFailure if err.errno in _MACHINE_ERRNOS else MiketalkError
            raise kind(
                f"cannot write {renames[0][1]}: {err.strerror or err}; it was left as it was"
            ) from None
        return
    first = renames[0][1]
    journal = first.parent / f".{first.name}.{_MARK}{owner_tag()}{_JOURNAL_SUFFIX}"
    entries = [
        {
            "temporary": tmp.name,
            "final": final.name,
            "inode": os.stat(tmp).st_ino,
            "backup": f".{final.name}.{_MARK}{owner_tag()}.{os.urandom(4).hex()}.old",
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
                _back_up(first.parent, entry)
            for tmp, final in renames:
                os.replace(tmp, final)
        except BaseException as err:
            roll_back(journal)
            if isinstance(err, OSError):
                where = err.filename or first
                kind = MachineFailure if err.errno in _MACHINE_ERRNOS else MiketalkError
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
_MACHINE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EIO})

#: The ``format`` of a journal (a journal of older miketalks is a list of renames).
JOURNAL_FORMAT = "miketalk-journal/2"


def _back_up(directory: Path, entry: dict) -> None:
    """Keep the old file of ``entry`` under its backup name (a hard link, else a copy)."""
    final, backup = directory / entry["final"], directory / entry["backup"]
    if not final.is_file() or final.is_symlink():
        return
    try:
        os.link(final, backup)
    except OSError:
        shutil.copy2(final, backup)


def _entries(journal: Path) -> list[dict] | None:
    """The files of ``journal`` (an older journal's renames become entries without inode)."""
    try:
        doc = json.loads(journal.read_text())
    except (OSError, ValueError):
        return None
    if isinstance(doc, list):  # miketalk's first journals: [[temporary, final], ...]
        doc = {"files": [{"temporary": t, "final": f} for t, f in doc]}
    files = doc.get("files") if isinstance(doc, dict) else None
    if not isinstance(files, list):
        return None
    plain = [
        e for e in files
        if isinstance(e, dict)
        and all(Path(str(e.get(k))).name == str(e.get(k)) for k in ("temporary", "final"))
        and (e.get("backup") is None or Path(str(e["backup"])).name == e["backup"])
    ]  # fmt: skip
    return plain if len(plain) == len(files) else None


def _is_new(path: Path, entry: dict) -> bool:
    """Whether the file at ``path`` is the unit's new file (its inode is the journal's)."""
    try:
        return entry.get("inode") is not None and os.stat(path).st_ino == entry["inode"]
    except OSError:
        return False


def roll_back(journal: str | os.PathLike[str]) -> None:
    """Put back the old files of the unit ``journal`` records; remove its new files, its
    temporary files, its backups and then the journal (each step can be done again)."""
    journal = Path(journal)
    directory = journal.parent
    entries = _entries(journal) or []
    for entry in entries:
        final = directory / entry["final"]
        backup = directory / entry["backup"] if entry.get("backup") else None
        if _is_new(final, entry):
            if backup is not None and backup.is_file():
                os.replace(backup, final)
            else:
                final.unlink()
        if backup is not None:
            backup.unlink(missing_ok=True)
        (directory / entry["temporary"]).unlink(missing_ok=True)
    journal.unlink(missing_ok=True)


def roll_forward(journal: str | os.PathLike[str]) -> bool:
    """Finish the unit ``journal`` records when every new file is in place or still there;
    False (nothing done) when one is lost."""
    journal = Path(journal)
    directory = journal.parent
    entries = _entries(journal)
    if entries is None:
        return False
    pending = []
    for entry in entries:
        final, tmp = directory / entry["final"], directory / entry["temporary"]
        if _replaced_since(directory, entry):
            return False
        if tmp.is_file():
            pending.append((tmp, final))
        elif not _is_new(final, entry) and entry.get("inode") is not None:
            return False
    for tmp, final in pending:
        os.replace(tmp, final)
        log.warning("finished replacing %s, interrupted when its run was killed", final)
    journal.unlink(missing_ok=True)
    for entry in entries:
        if entry.get("backup"):
            (directory / entry["backup"]).unlink(missing_ok=True)
    return True


def _replaced_since(directory: Path, entry: dict) -> bool:
    """Whether ``entry``'s final file was published by someone else after its unit was
    killed: it is neither the unit's new file nor the old one its backup links to."""
    if entry.get("inode") is None:  # a first-format journal: no way to tell
        return False
    try:
        now = os.stat(directory / entry["final"]).st_ino
    except OSError:
        return False
    if now == entry["inode"]:
        return False
    try:
        return now != os.stat(directory / entry["backup"]).st_ino if entry.get("backup") else True
    except OSError:
        return True


def _recover(journal: Path) -> None:
    """Settle the unit of a killed run's ``journal``: forward when it can, else back."""
    try:
        if not roll_forward(journal):
            roll_back(journal)
            log.warning(
                "put back the files a killed run was replacing beside %s (its new files "
                "were incomplete)", journal.parent,
            )  # fmt: skip
    except OSError as err:
        log.warning("cannot settle %s, left by a killed run: %s", journal, err)


def _recover_beside(path: Path) -> None:
    """Settle the units of killed runs that were publishing ``path`` (lock held)."""
    try:
        names = sorted(os.listdir(path.parent))
    except OSError:
        return
    for name in names:
        match = _BESIDE.match(name)
        if (
            match is not None
            and match["name"] == path.name
            and "." + match["rest"] == _JOURNAL_SUFFIX
            and not tag_owner_alive(match["tag"])
        ):
            _recover(path.parent / name)


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
        match = _BESIDE.match(name)
        if match is not None and not tag_owner_alive(match["tag"]):
            stale.append((name, match))
    removed = []
    for name, match in stale:
        if "." + match["rest"] == _JOURNAL_SUFFIX:
            journal = directory / name
            with output_lock(directory / match["name"]):
                if journal.exists():
                    _recover(journal)
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
