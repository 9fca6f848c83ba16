"""Uploads: a file's bytes, kept under a name the server makes until a job takes it.

The page sends each file as the raw body of one request (``POST /api/upload?kind=...``), its
name in a header. The name is only shown: the file is written as ``<random id><suffix>`` in the
results' ``.uploads/`` folder, the suffix kept only when it is one the kind allows (ffmpeg reads
a video or a recording by its content; subtitles are told from a transcript by ``.srt`` /
``.vtt``). A body over the size limit is refused before it is read. A job then moves the
file into its own folder (:meth:`Uploads.take`); what no job takes is removed after an hour.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import threading
import time
import unicodedata
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from miketalk.api import MiketalkError

#: The suffixes each kind of upload keeps (any other is dropped).
SUFFIXES: dict[str, frozenset[str]] = {
    "video": frozenset(".mp4 .mov .mkv .avi .webm .mpg .mpeg .m4v".split()),
    "audio": frozenset(".wav .mp3 .m4a .aac .ogg .oga .opus .flac .webm .mp4 .mpg .mkv".split()),
    "script": frozenset(".txt .srt .vtt".split()),
}
#: How long an upload no job took is kept, seconds.
KEEP_SECONDS = 3600.0
_CHUNK = 1 << 20
_ID = re.compile(r"u[0-9a-f]{32}")


class UploadRefused(MiketalkError):
    """An upload the server will not keep: one line, and the HTTP status that goes with it."""

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class Upload:
    """One file received: its id, kind, where the server keeps it, the name it was sent with."""

    id: str
    kind: str
    path: Path
    name: str
    size: int
    received: float


def display_name(raw: str | None) -> str:
    """A name to show for an upload: its last path part, without control characters, short.

    It is never used as a path.
    """
    name = re.split(r"[\\/]", raw or "")[-1]
    name = "".join(c for c in name if unicodedata.category(c)[0] != "C").strip()
    if len(name) > 120:
        name = name[:100] + "..." + name[-17:]
    return name or "upload"


def megabytes(n: int) -> str:
    """``n`` bytes as megabytes for a message."""
    return f"{n / (1 << 20):.1f}".removesuffix(".0") + " MB"


class Uploads:
    """The uploads waiting for a job (see the module docstring).

    Parameters
    ----------
    directory : Path
        Where they wait (emptied at start: what a stopped server left).
    max_bytes : int
        The largest upload.
    """

    def __init__(self, directory: Path, max_bytes: int) -> None:
        self.directory = directory
        self.max_bytes = max_bytes
        self._lock = threading.Lock()
        self._waiting: dict[str, Upload] = {}
        shutil.rmtree(directory, ignore_errors=True)
        directory.mkdir(parents=True, exist_ok=True)

    def check(self, kind: str, raw_name: str | None, length: int | None) -> None:
        """Refuse an unknown kind, a body of unknown length, an empty one or one over the
        limit, unread.

        Raises
        ------
        UploadRefused
            In one line, naming the limit.
        """
        if kind not in SUFFIXES:
            raise UploadRefused(f"unknown kind of upload {kind!r}: {', '.join(SUFFIXES)}")
        name = display_name(raw_name)
        if length is None:
            raise UploadRefused("an upload must say its length (Content-Length)", 411)
        if length <= 0:
            raise UploadRefused(f"{name} is empty")
        if length > self.max_bytes:
            raise UploadRefused(
                f"{name} is {megabytes(length)}: larger than the upload limit of "
                f"{megabytes(self.max_bytes)} (miketalk serve --max-upload-mb)",
                413,
            )

    def receive(
        self, kind: str, raw_name: str | None, length: int | None, body: BinaryIO
    ) -> Upload:
        """Keep ``length`` bytes of ``body`` as a new upload of ``kind``.

        Raises
        ------
        UploadRefused
            An upload refused by :meth:`check`, a body shorter than
            its length.
        """
        self.check(kind, raw_name, length)
        name = display_name(raw_name)
        self.sweep()
        suffix = os.path.splitext(name)[1].lower()
        upload_id = "u" + secrets.token_hex(16)
        path = self.directory / (upload_id + (suffix if suffix in SUFFIXES[kind] else ""))
        left = length
        try:
            with open(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "wb") as out:
                while left > 0:
                    chunk = body.read(min(_CHUNK, left))
                    if not chunk:
                        raise UploadRefused(f"the upload of {name} was cut off; send it again")
                    out.write(chunk)
                    left -= len(chunk)
        except BaseException:
            path.unlink(missing_ok=True)
            raise
        upload = Upload(upload_id, kind, path, name, length, time.monotonic())
        with self._lock:
            self._waiting[upload_id] = upload
        return upload

    def take(self, upload_id: object, kinds: tuple[str, ...], folder: Path, stem: str) -> Upload:
        """Move a waiting upload into a job's ``folder`` as ``stem`` + its suffix.

        Raises
        ------
        MiketalkError
            No such upload waiting (or of another kind).
        """
        with self._lock:
            upload = self._waiting.get(upload_id) if isinstance(upload_id, str) else None
            if upload is None or not _ID.fullmatch(upload.id) or upload.kind not in kinds:
                raise MiketalkError("the file was not received: choose it again")
            del self._waiting[upload.id]
        target = folder / (stem + upload.path.suffix)
        os.replace(upload.path, target)
        return Upload(upload.id, upload.kind, target, upload.name, upload.size, upload.received)

    def sweep(self, now: float | None = None) -> None:
        """Remove the uploads that waited longer than :data:`KEEP_SECONDS`."""
        now = time.monotonic() if now is None else now
        with self._lock:
            old = [u for u in self._waiting.values() if now - u.received > KEEP_SECONDS]
            for upload in old:
                del self._waiting[upload.id]
        for upload in old:
            with contextlib.suppress(OSError):
                upload.path.unlink()
