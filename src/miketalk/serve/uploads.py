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

    def check(
        self, kind: str, raw_name: str | None, length: int | None, *, chunked: bool = False
    ) -> None:
        """Refuse an unknown kind, a body of unknown length (unless ``chunked``: its length
        is counted as it comes), an empty one or one over the limit, unread.

        Raises
        ------
        UploadRefused
            In one line, naming the limit.
        """
        if kind not in SUFFIXES:
            raise UploadRefused(f"unknown kind of upload {kind!r}: {', '.join(SUFFIXES)}")
        name = display_name(raw_name)
        if length is None:
            if not chunked:
                raise UploadRefused("an upload must say its length (Content-Length)", 411)
            return
        if length <= 0:
            raise UploadRefused(f"{name} is empty")
        if length > self.max_bytes:
            raise UploadRefused(self.too_large(name, megabytes(length)), 413)

    def too_large(self, name: str, size: str) -> str:
        """The line refusing ``name`` of ``size`` over the limit."""
        return (
            f"{name} is {size}: larger than the upload limit of {megabytes(self.max_bytes)} "
            "(miketalk serve --max-upload-mb)"
        )

    def begin(self, kind: str, raw_name: str | None, length: int | None) -> Receiving:
        """Start keeping a new upload of ``kind``: its bytes are written as they come
        (:meth:`Receiving.write`), of ``length`` bytes, or of any length up to the limit when
        the body is chunked (``length`` None).

        Raises
        ------
        UploadRefused
            An upload refused by :meth:`check`.
        """
        self.check(kind, raw_name, length, chunked=length is None)
        name = display_name(raw_name)
        self.sweep()
        suffix = os.path.splitext(name)[1].lower()
        upload_id = "u" + secrets.token_hex(16)
        path = self.directory / (upload_id + (suffix if suffix in SUFFIXES[kind] else ""))
        out = open(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "wb")
        return Receiving(self, Upload(upload_id, kind, path, name, 0, 0.0), length, out)

    def _keep(self, upload: Upload) -> None:
        with self._lock:
            self._waiting[upload.id] = upload

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


class Receiving:
    """An upload being received: its bytes written as they come, kept by :meth:`done`,
    removed by :meth:`discard` (a body cut off, stalled, or over the limit)."""

    def __init__(self, uploads: Uploads, upload: Upload, length: int | None, out: BinaryIO):
        self._uploads, self._upload, self._length, self._out = uploads, upload, length, out
        self.received = 0

    def write(self, chunk: bytes) -> None:
        """Write the next ``chunk`` of the body.

        Raises
        ------
        UploadRefused
            More than its length, or (chunked) more than the limit: 413.
        """
        self.received += len(chunk)
        limit = self._uploads.max_bytes if self._length is None else self._length
        if self.received > limit:
            name = self._upload.name
            if self._length is None:
                line = self._uploads.too_large(name, f"over {megabytes(limit)}")
            else:
                line = f"{name}: more bytes came than its length ({self._length})"
            raise UploadRefused(line, 413)
        self._out.write(chunk)

    def done(self) -> Upload:
        """Keep the upload, now whole.

        Raises
        ------
        UploadRefused
            A body shorter than its length, or empty.
        """
        self._out.close()
        name = self._upload.name
        if self._length is not None and self.received < self._length:
            raise UploadRefused(f"the upload of {name} was cut off; send it again")
        if self.received == 0:
            raise UploadRefused(f"{name} is empty")
        u = self._upload
        upload = Upload(u.id, u.kind, u.path, u.name, self.received, time.monotonic())
        self._uploads._keep(upload)
        return upload

    def discard(self) -> None:
        """Remove what was written (nothing of it is kept)."""
        with contextlib.suppress(OSError):
            self._out.close()
        self._upload.path.unlink(missing_ok=True)
