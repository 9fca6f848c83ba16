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


def file_entry(path: str | os.PathLike[str]) -> dict:
    """What a manifest's ``files`` records of a file: ``{"size", "sha256"}``."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return {"size": os.path.getsize(path), "sha256": digest.hexdigest()}


def check_files(
    directory: str | os.PathLike[str], manifest: dict, flows: FlowDatabase, visemes: Sequence[str]
) -> None:
    """Check, when a model is opened, that every file it needs is there and whole.

    Every flow file of ``visemes`` exists, and is a whole OpenEXR file (its header and
    chunk table, :func:`miketalk.flow.exr.check_flow_file`); every file the manifest's
    ``files`` lists (a model written since checksums were recorded) has its size there.
    The SHA-256 of a listed file is checked when it is read (:func:`check_digest`).

    Raises
    ------
    MiketalkError
        In one line naming the first bad file.
    """
    from miketalk.flow.exr import check_flow_file

    check_complete(flows, list(visemes))
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
    for a, b in combinations(visemes, 2):
        check_flow_file(flows.path_for(a, b))


def check_digest(directory: str | os.PathLike[str], manifest: dict, path: Path) -> None:
    """Check ``path``'s SHA-256 against the manifest's ``files`` (nothing when not listed).

    Raises
    ------
    MiketalkError
        In one line naming the file.
    """
    try:
        relative = path.relative_to(directory).as_posix()
    except ValueError:
        return
    entry = manifest.get("files", {}).get(relative)
    if entry is not None and file_entry(path)["sha256"] != entry["sha256"]:
        raise MiketalkError(
            f"model file {path} does not match its checksum in the manifest: the model is "
            "damaged; rebuild it"
        )
