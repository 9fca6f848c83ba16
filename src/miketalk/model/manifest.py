"""A model directory's manifest: read, validated against its schema, paths kept inside the model."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from functools import cache
from importlib import resources
from itertools import combinations
from pathlib import Path, PurePosixPath
from typing import Any

from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase

FORMAT = "miketalk-model/1"


@cache
def _manifest_validator() -> Any:
    import jsonschema  # here: only opening a model needs it

    schema = json.loads(
        resources.files("miketalk").joinpath("data/model_manifest.schema.json").read_text()
    )
    return jsonschema.Draft202012Validator(schema)


def _no_constants(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def strict_json(text: str) -> Any:
    """``json.loads`` that refuses ``NaN``, ``Infinity`` and ``-Infinity`` (not JSON)."""
    return json.loads(text, parse_constant=_no_constants)


def read_manifest(directory: str | os.PathLike[str]) -> dict:
    """The checked manifest of the model in ``directory`` (see the module docstring).

    Raises
    ------
    MiketalkError
        Naming the manifest and what is wrong with it.
    """
    path = Path(directory) / "manifest.json"
    if not path.is_file():
        raise MiketalkError(f"no model at {directory} (missing manifest.json)")
    try:
        manifest = strict_json(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise MiketalkError(f"cannot read model manifest {path}: {err}") from None
    if isinstance(manifest, dict) and manifest.get("format") != FORMAT:
        raise MiketalkError(
            f"{path} is not a {FORMAT} manifest (its format is {manifest.get('format')!r})"
        )
    errors = sorted(_manifest_validator().iter_errors(manifest), key=lambda e: list(e.path))
    if errors:
        error = errors[0]
        where = "/".join(str(p) for p in error.absolute_path) or "the top level"
        raise MiketalkError(f"{path} is not a {FORMAT} manifest: at {where}, {error.message}")
    visemes = manifest["visemes"]
    lacking = [v for v in visemes if v not in manifest["images"]]
    if lacking:
        raise MiketalkError(f"{path}: no image for viseme(s) {', '.join(lacking)}")
    pairs = [f"{a}|{b}" for a in visemes for b in visemes if a != b]
    missing = [p for p in pairs if p not in manifest["max_displacement"]]
    if missing:
        raise MiketalkError(
            f"{path}: max_displacement lacks {len(missing)} pair(s), e.g. {missing[0]!r}"
        )
    for viseme in visemes:
        inside(directory, manifest["images"][viseme], f"the image of viseme {viseme!r}")
    return manifest


def inside(directory: str | os.PathLike[str], relative: str, what: str) -> Path:
    """``directory / relative``, for a path that stays inside ``directory``.

    Raises
    ------
    MiketalkError
        For an absolute path, a drive, a backslash, or a ``..`` component.
    """
    posix = PurePosixPath(relative)
    if posix.is_absolute() or ".." in posix.parts or "\\" in relative or ":" in relative:
        raise MiketalkError(
            f"{what}, {relative!r}, is outside the model directory {directory}: a manifest "
            "names files by paths relative to its directory, inside it"
        )
    return Path(directory) / posix


def check_complete(flows: FlowDatabase, visemes: tuple[str, ...] | list[str]) -> None:
    """Raise MiketalkError naming the first missing pair file of ``visemes``."""
    for a, b in combinations(visemes, 2):
        path = flows.path_for(a, b)
        if not path.exists():
            raise MiketalkError(f"flow file {path} for visemes {a!r} and {b!r} is missing")


def file_digest(path: str | os.PathLike[str]) -> str:
    """The SHA-256 of a file's bytes, in hex (read in blocks; the hash runs without the GIL)."""
    import hashlib

    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def file_entry(path: str | os.PathLike[str]) -> dict:
    """What a manifest's ``files`` records of a file: ``{"size", "sha256"}``."""
    return {"size": os.path.getsize(path), "sha256": file_digest(path)}


#: Threads hashing a model's files when it opens (SHA-256 in C, without the GIL).
DIGEST_THREADS = max(1, min(2, os.cpu_count() or 1))


def files_stat(directory: str | os.PathLike[str], manifest: dict) -> tuple:
    """``(name, size, mtime_ns, inode)`` of each file the manifest's ``files`` lists (None
    for one that cannot be read): what tells a model kept open that a file changed since."""
    stats = []
    for relative in sorted(manifest.get("files", {})):
        try:
            st = os.stat(inside(directory, relative, "a file of the manifest"))
        except OSError:
            stats.append((relative, None))
        else:
            stats.append((relative, st.st_size, st.st_mtime_ns, st.st_ino))
    return tuple(stats)


def check_files(
    directory: str | os.PathLike[str], manifest: dict, flows: FlowDatabase, visemes: Sequence[str]
) -> tuple:
    """Check, when a model is opened, that every file it needs is there and whole.

    Every flow file of ``visemes`` exists, and is a whole OpenEXR file (its header and
    chunk table, :func:`miketalk.flow.exr.check_flow_file`); every file the manifest's
    ``files`` lists (a model written since checksums were recorded: its viseme images
    and flow files) exists, has its size there, and its SHA-256: all of them, not only
    those a text's transitions read (128 MB for a 256-pixel model, 0.1 to 0.3 s on two
    busy cores; docs/safety.md).

    Returns
    -------
    tuple
        The files' :func:`files_stat`, taken before they were read.

    Raises
    ------
    MiketalkError
        In one line naming the first bad file (in the order of their names).
    """
    from concurrent.futures import ThreadPoolExecutor

    from miketalk.flow.exr import check_flow_file
    from miketalk.workers import map_in_pool

    check_complete(flows, list(visemes))
    stat = files_stat(directory, manifest)
    listed = []
    for relative, entry in sorted(manifest.get("files", {}).items()):
        path = inside(directory, relative, "a file of the manifest")
        try:
            size = path.stat().st_size
        except OSError:
            raise MiketalkError(
                f"model file {path} is missing: the model is damaged; rebuild it"
            ) from None
        if size != entry["size"]:
            raise MiketalkError(
                f"model file {path} is {size} bytes, the manifest says {entry['size']}: the "
                "model is damaged; rebuild it"
            )
        listed.append((path, entry["sha256"]))
    for a, b in combinations(visemes, 2):
        check_flow_file(flows.path_for(a, b))

    def digest(path: Path) -> str | None:
        try:
            return file_digest(path)
        except OSError:  # removed or unreadable since its size was read
            return None

    with ThreadPoolExecutor(DIGEST_THREADS, thread_name_prefix="miketalk-digest") as pool:
        digests = list(map_in_pool(pool, digest, [path for path, _ in listed]))
    for (path, expected), found in zip(listed, digests, strict=True):
        if found is None:
            raise MiketalkError(f"model file {path} cannot be read: the model is damaged")
        if found != expected:
            raise MiketalkError(
                f"model file {path} does not match its checksum in the manifest: the model "
                "is damaged; rebuild it"
            )
    return stat
