"""Whether miketalk may write a file: never over what it did not write, never over an input.

The one rule of every command that writes (``say``, ``dub``, ``cues``, ``build``) and of any
other front end: :func:`check_replaceable`, called before any work and again just before the
new files are published (:func:`miketalk.media.atomic.atomic_paths`' ``guard``).

* An output that does not exist may be written.
* An output that is one of the inputs (the same file, also through a symbolic or a hard
  link: compared by device and inode) is always refused, ``force`` or not; so is an output
  directory (a model) that holds an input.
* An output that exists is replaced only when miketalk wrote it, as far as the file shows:

  - an mp4 (:attr:`Kind.VIDEO`): its timeline JSON beside it is a miketalk timeline that
    names it (its size and SHA-256, ``mp4`` in the JSON; a timeline from before they were
    recorded is taken as naming it);
  - a timeline JSON (:attr:`Kind.TIMELINE`): a miketalk timeline
    (:func:`miketalk.talk.output.is_timeline`);
  - mouth cues (:attr:`Kind.CUES_JSON`, :attr:`Kind.CUES_TSV`, :attr:`Kind.TEXTGRID`): a
    file whose record beside it (:func:`record_path`, ``.NAME.miketalk.json``, written
    with it) names its size and SHA-256. Its format tells nothing: Rhubarb writes the same
    JSON and TSV, and a file miketalk wrote and the user then tuned by hand is the user's;
  - a wav (:attr:`Kind.WAV`): one whose RIFF ``INFO`` chunk names miketalk as its software
    (``ISFT``), as :func:`miketalk.media.audio.write_wav` marks it when asked;
  - a model directory (:attr:`Kind.MODEL`): a directory with a model manifest, replaced
    (with ``force``) only when it holds nothing but the files its manifest names
    (:func:`foreign_entry`): a user's notes kept in an older model's folder are never removed.

  Anything else (a file of another kind, a directory where a file goes, a device) is refused
  in one line unless ``force``, which replaces a regular file of any kind (never a directory
  where a file goes, never an input). A read-only file is refused even with ``force``: its
  owner made it so.

Only the standard library is used: the command line checks its outputs before Festival starts,
and Festival starts before numpy loads.
"""

from __future__ import annotations

import enum
import hashlib
import json
import os
from collections.abc import Iterable
from pathlib import Path, PurePosixPath

from miketalk.errors import MiketalkError

__all__ = [
    "Kind",
    "check_replaceable",
    "file_record",
    "foreign_entry",
    "model_files",
    "record_path",
    "record_text",
    "same_file",
    "written_by_miketalk",
]

#: The ``format`` of the timeline JSON :func:`miketalk.talk.say.say` writes.
TIMELINE_FORMAT = "miketalk-timeline/1"

#: The software name a miketalk wav carries in its RIFF INFO chunk (``ISFT``).
WAV_SOFTWARE = b"miketalk"


class Kind(enum.Enum):
    """What an output is (each kind has its own test of having been written by miketalk)."""

    VIDEO = "video"
    TIMELINE = "timeline"
    CUES_JSON = "cues-json"
    CUES_TSV = "cues-tsv"
    TEXTGRID = "textgrid"
    WAV = "wav"
    MODEL = "model"

    @property
    def words(self) -> str:
        """What the kind is, in a message."""
        return _WORDS[self]


_WORDS = {
    Kind.VIDEO: "an mp4 miketalk wrote (with its timeline JSON beside it)",
    Kind.TIMELINE: "a miketalk timeline",
    Kind.CUES_JSON: "mouth cues miketalk wrote, unchanged since (Rhubarb JSON)",
    Kind.CUES_TSV: "mouth cues miketalk wrote, unchanged since (Rhubarb TSV)",
    Kind.TEXTGRID: "a TextGrid miketalk wrote, unchanged since",
    Kind.WAV: "a wav miketalk wrote",
    Kind.MODEL: "a miketalk model",
}


def file_record(path: str | os.PathLike[str]) -> dict:
    """What a timeline JSON records of its mp4: ``{"name", "size", "sha256"}``."""
    path = Path(path)
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return {"name": path.name, "size": path.stat().st_size, "sha256": digest.hexdigest()}


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether ``a`` and ``b`` are one file (device and inode: links included); False when
    either does not exist."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _json(path: Path) -> object:
    try:
        with path.open("rb") as f:
            data = f.read(64 << 20)  # a timeline of hours is tens of MB; more is not ours
        return json.loads(data.decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None


def _is_timeline_doc(doc: object) -> bool:
    if not isinstance(doc, dict):
        return False
    return doc.get("format") == TIMELINE_FORMAT or {"fps", "frames", "transitions"} <= set(doc)


def _video_is_ours(path: Path) -> bool:
    doc = _json(path.with_suffix(".json"))
    if not _is_timeline_doc(doc):
        return False
    record = doc.get("mp4")
    if not isinstance(record, dict):
        return True  # a timeline from before the mp4 was recorded in it
    try:
        if path.stat().st_size != record.get("size"):
            return False
        return file_record(path)["sha256"] == record.get("sha256")
    except OSError:
        return False


#: The ``format`` of the record miketalk keeps beside a file it wrote (:func:`record_path`).
RECORD_FORMAT = "miketalk-written/1"


def record_path(path: str | os.PathLike[str]) -> Path:
    """The record of ``path`` that says miketalk wrote it: ``.NAME.miketalk.json`` beside it."""
    path = Path(path)
    return path.parent / f".{path.name}.miketalk.json"


def record_text(name: str, data: bytes) -> str:
    """The record (:func:`record_path`) of a file named ``name`` that miketalk writes with
    the bytes ``data``: its name, size and SHA-256."""
    doc = {"format": RECORD_FORMAT, "name": name, "size": len(data)}
    return json.dumps(doc | {"sha256": hashlib.sha256(data).hexdigest()}) + "\n"


def _recorded(path: Path) -> bool:
    """Whether the record beside ``path`` names it as it is now (its size and SHA-256)."""
    doc = _json(record_path(path))
    if not isinstance(doc, dict) or doc.get("format") != RECORD_FORMAT:
        return False
    try:
        if doc.get("name") != path.name or path.stat().st_size != doc.get("size"):
            return False
        return file_record(path)["sha256"] == doc.get("sha256")
    except OSError:
        return False


def _wav_is_ours(path: Path) -> bool:
    try:
        with path.open("rb") as f:
            head = f.read(12)
            if head[:4] != b"RIFF" or head[8:12] != b"WAVE":
                return False
            while chunk := f.read(8):
                if len(chunk) < 8:
                    return False
                name, size = chunk[:4], int.from_bytes(chunk[4:], "little")
                if name == b"LIST":
                    body = f.read(size)
                    return body[:4] == b"INFO" and b"ISFT" in body and WAV_SOFTWARE in body
                f.seek(size + (size & 1), os.SEEK_CUR)
    except OSError:
        return False
    return False


def _model_is_ours(path: Path) -> bool:
    doc = _json(path / "manifest.json")
    return isinstance(doc, dict) and str(doc.get("format", "")).startswith("miketalk-model/")


_OURS = {
    Kind.VIDEO: _video_is_ours,
    Kind.TIMELINE: lambda p: _is_timeline_doc(_json(p)),
    Kind.CUES_JSON: _recorded,
    Kind.CUES_TSV: _recorded,
    Kind.TEXTGRID: _recorded,
    Kind.WAV: _wav_is_ours,
    Kind.MODEL: _model_is_ours,
}


def written_by_miketalk(path: str | os.PathLike[str], kind: Kind) -> bool:
    """Whether the existing ``path`` is a ``kind`` of file miketalk wrote (module docstring)."""
    return _OURS[kind](Path(path))


def check_replaceable(
    path: str | os.PathLike[str],
    kind: Kind,
    *,
    inputs: Iterable[str | os.PathLike[str] | None] = (),
    force: bool = False,
    option: str = "-o",
) -> Path:
    """Check that miketalk may write ``path`` (see the module docstring); return it.

    An mp4 (:attr:`Kind.VIDEO`) is checked with its timeline JSON beside it.

    Parameters
    ----------
    path : path-like
        The output.
    kind : Kind
        What is written there.
    inputs : iterable of path-like
        The files (or directories) the command reads (None entries are skipped).
    force : bool
        Replace an existing regular file miketalk did not write (never an input, a
        directory where a file goes, or a read-only file).
    option : str
        The option that named ``path``, for the message.

    Raises
    ------
    MiketalkError
        In one line, naming the file and what to do.
    """
    path = Path(path)
    given = [Path(p) for p in inputs if p is not None]
    targets = [path, path.with_suffix(".json")] if kind == Kind.VIDEO else [path]
    for target in targets:
        for source in given:
            if same_file(target, source):
                raise MiketalkError(
                    f"{target} is also an input ({source}): miketalk never writes over what "
                    f"it reads; give another {option}"
                )
    if kind == Kind.MODEL:
        _check_model_dir(path, given, force=force, option=option)
        return path
    present = [
        (target, what)
        for target, what in zip(targets, (kind, Kind.TIMELINE), strict=False)
        if os.path.lexists(target)
    ]
    for target, what in present:
        if target.is_dir():
            raise MiketalkError(
                f"{target} is a directory, where miketalk would write "
                f"{what.words.split(' (')[0]}: give another {option} (or move the directory)"
            )
        if not target.is_file():
            raise MiketalkError(f"{target} is not a regular file: give another {option}")
        if not os.access(target, os.W_OK) or not target.stat().st_mode & 0o222:
            raise MiketalkError(
                f"{target} is read-only: miketalk does not replace it; make it writable or "
                f"give another {option}"
            )
    for target, what in present:
        if force or written_by_miketalk(target, what):
            continue
        if what == Kind.VIDEO:
            why = f"miketalk did not write it (no timeline {target.with_suffix('.json').name} "
            why += "beside it names it)"
        else:
            why = f"is not {what.words}"
        raise MiketalkError(
            f"{target} exists and {why}: move it, give another {option}, or replace it with --force"
        )
    return path


def _check_model_dir(path: Path, inputs: list[Path], *, force: bool, option: str) -> None:
    resolved = path.resolve()
    for source in inputs:
        try:
            inside = source.resolve().is_relative_to(resolved)
        except OSError:
            inside = False
        if inside and os.path.lexists(path):
            raise MiketalkError(
                f"{path} holds an input ({source}): miketalk never replaces what it reads; "
                f"give another {option}"
            )
    if not os.path.lexists(path):
        return
    if not path.is_dir():
        raise MiketalkError(f"{path} exists and is not a directory: give another {option}")
    if not written_by_miketalk(path, Kind.MODEL):
        raise MiketalkError(f"{path} exists and holds something else: give another {option}")
    if not force:
        raise MiketalkError(
            f"{path} exists and holds a model: give another {option} or --force to replace it"
        )
    if model_files(path) is None:
        raise MiketalkError(
            f"{path} holds a model whose manifest does not list its files (one written before "
            f"they were listed): miketalk cannot tell them from yours; empty it yourself, or "
            f"give another {option}"
        )
    foreign = foreign_entry(path)
    if foreign is not None:
        raise MiketalkError(
            f"{path} holds {foreign}, which its manifest does not name: --force replaces only "
            f"a model's own files; move it out of {path}, or give another {option}"
        )


def model_files(path: str | os.PathLike[str]) -> frozenset[str] | None:
    """The files the model in ``path`` names as its own (paths relative to it, ``/``-separated):
    ``manifest.json`` and its manifest's ``files``; None when the manifest lists none (a
    model written before its files were listed)."""
    doc = _json(Path(path) / "manifest.json")
    files = doc.get("files") if isinstance(doc, dict) else None
    if not isinstance(files, dict) or not files:
        return None
    return frozenset(files) | {"manifest.json"}


def foreign_entry(path: str | os.PathLike[str]) -> str | None:
    """The first file (in name order) of the model directory ``path`` that is not one of its
    own (:func:`model_files`), else the first folder that holds none of them: a user's file,
    folder or link kept there, which replacing the model would remove. None when there is none.

    Links are not followed (a link is an entry of its own, never one of the model's files);
    hidden files count.
    """
    path = Path(path)
    own = model_files(path) or frozenset({"manifest.json"})
    folders = {p for f in own for p in PurePosixPath(f).parents}
    empty = None
    for root, dirs, names in os.walk(path, onerror=_raise):
        base = PurePosixPath(Path(root).relative_to(path).as_posix())
        dirs.sort()
        links = [d for d in dirs if (Path(root) / d).is_symlink()]
        for name in sorted(names + links):
            if (base / name).as_posix() not in own or (Path(root) / name).is_symlink():
                return (base / name).as_posix()
        dirs[:] = [d for d in dirs if d not in links]
        for name in dirs:
            if empty is None and base / name not in folders:
                empty = (base / name).as_posix() + "/"
    return empty


def _raise(err: OSError) -> None:
    raise MiketalkError(f"cannot read {err.filename}: {err.strerror or err}") from None
