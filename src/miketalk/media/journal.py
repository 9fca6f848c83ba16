"""The journal of a unit of files being published (:mod:`miketalk.media.atomic`), and how a
unit a killed run left half published is settled: rolled forward when all its new files are
there, else back, so that the old files or the new ones stand, never some of each.

Temporary files and journals are named ``.<name>.miketalk-<pid>.<start>.<rest>`` beside
their final name ``<name>`` (:data:`BESIDE`); a journal's ``<rest>`` is ``commit``. It
holds, for each file of the unit, its temporary name, its final name, the temporary file's
inode and the name of a backup (a hard link) of the old file.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shutil
from pathlib import Path

from miketalk.media.scratch import tag_owner_alive

log = logging.getLogger(__name__)

#: What marks a name as miketalk's (after the final name and before the owner tag).
MARK = "miketalk-"
#: ``.<name>.miketalk-<pid>.<start>.<rest>``: a temporary file or journal of ``<name>``.
BESIDE = re.compile(r"^\.(?P<name>.+)\.miketalk-(?P<tag>\d+\.\d+)\.(?P<rest>[^/]+)$")
JOURNAL_SUFFIX = ".commit"


#: The ``format`` of a journal (a journal of older miketalks is a list of renames).
JOURNAL_FORMAT = "miketalk-journal/2"


def back_up(directory: Path, entry: dict) -> None:
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


def recover(journal: Path) -> None:
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


def recover_beside(path: Path) -> None:
    """Settle the units of killed runs that were publishing ``path`` (lock held)."""
    try:
        names = sorted(os.listdir(path.parent))
    except OSError:
        return
    for name in names:
        match = BESIDE.match(name)
        if (
            match is not None
            and match["name"] == path.name
            and "." + match["rest"] == JOURNAL_SUFFIX
            and not tag_owner_alive(match["tag"])
        ):
            recover(path.parent / name)
