"""Atomic file output: a file (or a set of files) appears complete under its final name, or
not at all, and an older version survives any failure.

Temporary files live beside their final names (so the rename is atomic) and
are named ``.<name>.miketalk-<pid>.<start>.<random><suffix>``: hidden, and
tagged with their owner (:mod:`miketalk.media.scratch`), so that what a
killed run left behind is recognised and removed by :func:`sweep_beside`.

:func:`atomic_paths` replaces several files together (an mp4 and its timeline
JSON): they are all written under temporary names first; then a small journal
(``.<first name>.miketalk-<tag>.commit``) lists the renames, the renames are
done with the catchable signals blocked, and the journal is removed. A run
killed during the renames (SIGKILL) leaves the journal, and the next
:func:`sweep_beside` finishes them, so the files are replaced together or
not at all.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

from miketalk.errors import MiketalkError
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
    paths: Sequence[str | os.PathLike[str]], *, suffixes: Sequence[str] | None = None
) -> Iterator[list[Path]]:
    """Temporary paths beside ``paths`` (one directory), renamed onto them together on success.

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

    Yields
    ------
    list of pathlib.Path
        Where to write each file.

    Raises
    ------
    MiketalkError
        If the directory cannot be created or written in.
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
        _commit(list(zip(temps, finals, strict=True)))
    except BaseException:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        raise


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
    """Rename each temporary file onto its final name, all or (after a crash, by the next
    :func:`sweep_beside`) all of them."""
    if len(renames) == 1:
        os.replace(*renames[0])
        return
    first = renames[0][1]
    journal = first.parent / f".{first.name}.{_MARK}{owner_tag()}{_JOURNAL_SUFFIX}"
    entries = [[tmp.name, final.name] for tmp, final in renames]
    with deferred_signals():
        staging = _temporary(journal, ".journal")
        staging.write_text(json.dumps(entries))
        os.replace(staging, journal)
        for tmp, final in renames:
            os.replace(tmp, final)
        journal.unlink()


def sweep_beside(path: str | os.PathLike[str]) -> list[Path]:
    """Tidy what killed runs left in ``path``'s directory; return the files removed.

    An unfinished set of renames (a journal whose owner is gone) is finished
    first, so a set of files written together is never left half replaced;
    then every temporary file and journal whose owner is gone is removed.
    Files of running processes and files without miketalk's tag are left alone.
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
    for name, match in stale:
        if "." + match["rest"] == _JOURNAL_SUFFIX:
            _finish_journal(directory / name)
    removed = []
    for name, _ in stale:
        victim = directory / name
        if victim.is_file() and not victim.is_symlink():
            victim.unlink(missing_ok=True)
            removed.append(victim)
            log.info("removed %s, left by a run that was killed", victim)
    return removed


def _finish_journal(journal: Path) -> None:
    try:
        entries = json.loads(journal.read_text())
    except (OSError, ValueError):
        return  # a journal is written whole before it gets its name: never reached
    for tmp_name, final_name in entries:
        tmp, final = journal.parent / tmp_name, journal.parent / final_name
        plain = Path(tmp_name).name == tmp_name and Path(final_name).name == final_name
        if plain and tmp.is_file():
            os.replace(tmp, final)
            log.warning("finished replacing %s, interrupted when its run was killed", final)


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    write_bytes_atomic(path, text.encode("utf-8"))
