"""A model directory's manifest: read, validated against its schema, paths kept inside the model."""

from __future__ import annotations

import json
import os
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
