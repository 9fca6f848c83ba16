"""What a run keeps for the next one: small records and decoded frames, in the user's cache.

Opening a model costs the SHA-256 of its files and the decoding of its background's PNG
frames; a command that opens the same unchanged model again (every ``miketalk say``)
need not pay either twice. :func:`cache_dir` is where such things are kept:
``$MIKETALK_CACHE`` when set, else ``$XDG_CACHE_HOME/miketalk``, else
``~/.cache/miketalk`` (None when none can be made: nothing is kept, everything is done as
if it were the first time). Every entry is written whole under a temporary name and then
renamed (:func:`~miketalk.media.atomic.write_bytes_atomic`), so a reader finds an entry
complete or not at all; an entry that cannot be read is ignored (and made again).

Entries are named by what they are made from (:func:`entry_name`: a SHA-256 of the key),
never by a path a user gave, and hold nothing a later run trusts beyond what its key
names: what was checked, and the stat of the files it was checked on.

Only the standard library is used (and, for :func:`ffmpeg_stamp`, the ffmpeg it names).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from pathlib import Path
from typing import Any

from miketalk.media.atomic import write_text_atomic

__all__ = [
    "CACHE_ENV",
    "cache_dir",
    "cache_root",
    "entry_name",
    "ffmpeg_stamp",
    "file_digest",
    "read_record",
    "source_digest",
    "write_record",
]

log = logging.getLogger(__name__)

#: The environment variable naming the cache's folder (``off``: keep nothing).
CACHE_ENV = "MIKETALK_CACHE"


def cache_root() -> Path:
    """The user's miketalk cache: ``$MIKETALK_CACHE``, else ``$XDG_CACHE_HOME/miketalk``, else
    ``~/.cache/miketalk`` (not made here)."""
    if env := os.environ.get(CACHE_ENV):
        return Path(env)
    if xdg := os.environ.get("XDG_CACHE_HOME"):
        return Path(xdg) / "miketalk"
    return Path.home() / ".cache" / "miketalk"


def cache_dir(kind: str) -> Path | None:
    """The folder ``kind`` of the user's miketalk cache (:func:`cache_root`), made if needed;
    None when ``$MIKETALK_CACHE`` is ``off`` or the folder cannot be made."""
    if os.environ.get(CACHE_ENV) == "off":
        return None
    where = cache_root() / kind
    try:
        where.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        log.debug("no cache at %s (%s): nothing is kept", where, err)
        return None
    return where if os.access(where, os.W_OK | os.X_OK) else None


def file_digest(path: str | os.PathLike[str]) -> str:
    """The SHA-256 of a file's bytes, in hex (read in blocks; the hash runs without the GIL)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def source_digest(parts: tuple[str, ...]) -> str:
    """The SHA-256 of the source of ``parts`` (paths under the ``miketalk`` package: a
    module, or a folder's modules in order of their paths): what made an entry, in its key."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for part in parts:
        where = root / part
        for path in sorted(where.rglob("*.py")) if where.is_dir() else [where]:
            digest.update(str(path.relative_to(root)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def ffmpeg_stamp() -> list:
    """ffmpeg's path, size and modification time (what decodes an entry's frames)."""
    from miketalk.media.x264 import ffmpeg_exe

    exe = ffmpeg_exe()
    stat = os.stat(exe)
    return [str(exe), stat.st_size, stat.st_mtime_ns]


def entry_name(*key: Any) -> str:
    """A file name for the entry made from ``key`` (JSON-able parts): their SHA-256."""
    text = json.dumps(key, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def read_record(kind: str, *key: Any) -> Any | None:
    """The record kept for ``key`` in ``kind`` (None: none, or one that cannot be read)."""
    where = cache_dir(kind)
    if where is None:
        return None
    path = where / f"{entry_name(*key)}.json"
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc.get("record") if isinstance(doc, dict) and doc.get("key") == _plain(key) else None


def write_record(kind: str, record: Any, *key: Any) -> bool:
    """Keep ``record`` for ``key`` in ``kind`` (whole or not at all); whether it was kept."""
    where = cache_dir(kind)
    if where is None:
        return False
    try:
        write_text_atomic(
            where / f"{entry_name(*key)}.json", json.dumps({"key": _plain(key), "record": record})
        )
    except Exception as err:  # a cache that cannot be written is no error
        log.debug("the %s record was not kept (%s)", kind, err)
        return False
    return True


def _plain(value: Any) -> Any:
    """``value`` as JSON reads it back (tuples as lists), to compare a stored key with."""
    return json.loads(json.dumps(value, sort_keys=True, default=str))
