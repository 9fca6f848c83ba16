"""dlib's frontal face detector, kept in the user's cache in dlib's binary form.

``dlib.get_frontal_face_detector()`` parses the detector from text built into dlib: 0.3 s
of CPU each time a thread of a run first tracks a face (a first ``dub``'s first look, its
tracking, each worker of a build), before any frame is looked at. The same detector saved
by dlib (``fhog_object_detector.save``, 155 kB) loads in a millisecond.
:func:`frontal_face_detector` keeps it in the user's cache
(:mod:`miketalk.media.user_cache`, kind :data:`KIND`), named
by dlib's version, with the SHA-256 of its bytes in a record beside it: a file whose bytes
do not match, or that dlib cannot read, is made again. Without a cache
(``$MIKETALK_CACHE=off``) the detector is made by dlib every time, as before. Either way it
is the same detector: the one loaded from the file serializes to the bytes of dlib's own.
"""

from __future__ import annotations

import hashlib
import logging
import os
from pathlib import Path
from typing import Any

__all__ = ["KIND", "frontal_face_detector"]

log = logging.getLogger(__name__)

#: The kind of cache entry (:func:`~miketalk.media.user_cache.cache_dir`).
KIND = "detectors"

#: The entry's layout; a change makes every old entry another key.
FORMAT = 1


def frontal_face_detector() -> Any:
    """dlib's frontal face detector: read from the user's cache where a run before kept it,
    else made by dlib (and kept)."""
    import dlib

    from miketalk.media.user_cache import cache_dir, entry_name, read_record, write_record

    where = cache_dir(KIND)
    if where is None:
        return dlib.get_frontal_face_detector()
    key = ("frontal_face_detector", dlib.__version__, FORMAT)
    path = where / f"{entry_name(*key)}.svm"
    record = read_record(KIND, *key)
    if isinstance(record, dict) and _digest(path) == record.get("sha256"):
        try:
            return dlib.fhog_object_detector(str(path))
        except Exception as err:  # unreadable after all: made again below
            log.debug("the kept face detector %s could not be read (%s)", path, err)
    detector = dlib.get_frontal_face_detector()
    scratch = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        detector.save(str(scratch))
        digest = _digest(scratch)
        os.replace(scratch, path)
        write_record(KIND, {"sha256": digest}, *key)
    except Exception as err:  # a cache that cannot be written is no error
        log.debug("the face detector was not kept (%s)", err)
        scratch.unlink(missing_ok=True)
    return detector


def _digest(path: Path) -> str | None:
    """The SHA-256 of a file's bytes in hex (None: it cannot be read)."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None
