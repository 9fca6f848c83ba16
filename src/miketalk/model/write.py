"""Writing a model directory: its visemes and flows (:func:`build_model`), where its other
parts go (:func:`write_coarticulation`, :func:`trained_folder`,
:func:`miketalk.model.background.save_background`), and the list of them all
(:func:`list_model_files`)."""

from __future__ import annotations

import json
import os
import shutil
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase
from miketalk.media.atomic import write_text_atomic
from miketalk.media.images import read_image
from miketalk.model.manifest import FORMAT, READ_IN_PARTS, check_complete, file_entry
from miketalk.model.parts import COARTICULATION, TRAINED_DIRECTORY
from miketalk.visemes import viseme_slug


def largest_displacement(flow: np.ndarray, *, quantile: float = 0.999) -> float:
    """The paper's "maximal offset vector" of a flow, robust to stray vectors.

    The 99.9th percentile of the vector lengths rather than the very longest:
    an estimated flow has a few wild vectors (textureless background, occlusion
    borders) that are no motion at all, and would make oversampling slow every
    transition down. On true flows the two agree to a fraction of a pixel.
    """
    length = np.sqrt((flow.astype(np.float64) ** 2).sum(axis=-1))
    return float(np.quantile(length, quantile))


def build_model(
    out_dir: str | os.PathLike[str],
    *,
    images: dict[str, str | os.PathLike[str]],
    flows_dir: str | os.PathLike[str],
    estimator: str,
    settings: dict,
    fallbacks: dict[str, str] | None = None,
) -> Path:
    """Assemble a model directory from viseme images and a flow database.

    Images and flow files are hard-linked where possible (copied otherwise);
    the manifest is written last, so a model without one is incomplete. The manifest
    lists each image and flow file with its size and SHA-256 (``files``), which
    :class:`~miketalk.model.face.Model` checks.
    ``fallbacks`` (viseme -> the class whose image it borrows, for a class the
    recording had no instance of) is listed in the manifest.
    """
    out = Path(out_dir)
    (out / "visemes").mkdir(parents=True, exist_ok=True)
    names = list(images)
    sizes = set()
    image_paths = {}
    for viseme, src in images.items():
        rel = f"visemes/{viseme_slug(viseme)}.png"
        sizes.add(read_image(src).shape[:2])
        _link(Path(src), out / rel)
        image_paths[viseme] = rel
    if len(sizes) != 1:
        raise MiketalkError(f"viseme images differ in size: {sorted(sizes)}")
    source = FlowDatabase(flows_dir)
    check_complete(source, names)
    if (out / "flows").exists():
        shutil.rmtree(out / "flows")
    (out / "flows").mkdir()
    for a, b in combinations(names, 2):
        path = source.path_for(a, b)
        _link(path, out / "flows" / path.name)
    displacement = {
        f"{a}|{b}": largest_displacement(source.flow(a, b)) for a in names for b in names if a != b
    }
    manifest = {
        "format": FORMAT,
        "visemes": names,
        "size": list(sizes.pop()),
        "estimator": estimator,
        "settings": settings,
        "images": image_paths,
        "max_displacement": displacement,
    }
    if fallbacks:
        manifest["fallbacks"] = dict(sorted(fallbacks.items()))
    # what tells a damaged model (a file cut short or changed) when it is opened and read
    listed = [
        *image_paths.values(),
        *(f"flows/{p.name}" for p in sorted((out / "flows").iterdir())),
    ]
    manifest["files"] = {rel: file_entry(out / rel) for rel in sorted(listed)}
    write_text_atomic(out / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True))
    return out


def write_coarticulation(out_dir: str | os.PathLike[str], params) -> Path:
    """Write a fitted coarticulation
    (:class:`~miketalk.draw.coarticulation.CoarticulationParams`) into the model in
    ``out_dir``; return its file."""
    from miketalk.draw.coarticulation import write_params

    return write_params(params, Path(out_dir) / COARTICULATION)


def trained_folder(out_dir: str | os.PathLike[str]) -> Path:
    """The folder of the model in ``out_dir`` its trained face is fitted into
    (:func:`miketalk.draw.trained.fit_trained`)."""
    return Path(out_dir) / TRAINED_DIRECTORY


def list_model_files(out_dir: str | os.PathLike[str]) -> int:
    """List every file of the model in ``out_dir`` in its manifest, once its last part is written.

    :func:`build_model` lists the images and flow files it writes; a face from clips then
    gets its coarticulation, trained face and background beside them. Each file not yet in
    the manifest's ``files`` (hidden ones aside: a temporary file, never a part) is added
    with its size and SHA-256 (:data:`~miketalk.model.manifest.READ_IN_PARTS` also block by
    block), and the manifest rewritten in one step (:func:`write_text_atomic`), or left as
    it is when nothing was added. ``build`` calls it again once its record of its work
    (``build/``) is copied in, so that the manifest names every file of the model: ``build
    --force`` replaces a model only when it holds nothing else
    (:func:`miketalk.media.ownership.check_replaceable`).

    Returns
    -------
    int
        The number of files added.
    """
    out = Path(out_dir)
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    files = dict(manifest.get("files", {}))
    added = 0
    for path in sorted(out.rglob("*")):
        relative = path.relative_to(out).as_posix()
        hidden = any(part.startswith(".") for part in path.relative_to(out).parts)
        if relative == "manifest.json" or hidden or relative in files or not path.is_file():
            continue
        files[relative] = file_entry(path, in_parts=relative in READ_IN_PARTS)
        added += 1
    if added:
        manifest["files"] = dict(sorted(files.items()))
        write_text_atomic(out / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True))
    return added


def fallbacks_of(visemes: pd.DataFrame) -> dict[str, str]:
    """``viseme -> donor`` from a ``visemes.tsv`` table's ``fallback`` column (empty: none)."""
    if "fallback" not in visemes.columns:
        return {}
    return {
        str(v): str(f)
        for v, f in zip(visemes["viseme"], visemes["fallback"], strict=True)
        if isinstance(f, str) and f
    }


def _link(src: Path, dst: Path) -> None:
    dst.unlink(missing_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)
