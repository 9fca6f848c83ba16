"""A model directory's manifest: read, validated against its schema, paths kept inside the model."""

from __future__ import annotations

import json
import os
import stat
import time
from collections.abc import Sequence
from functools import cache
from importlib import resources
from itertools import combinations
from pathlib import Path, PurePosixPath
from typing import Any

from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase
from miketalk.media.user_cache import file_digest, read_record, write_record

FORMAT = "miketalk-model/1"


@cache
def _manifest_validator() -> Any:
    import jsonschema  # here: only opening a model needs it

    schema = json.loads(
        resources.files("miketalk").joinpath("data/model_manifest.schema.json").read_text()
    )
    return jsonschema.Draft202012Validator(schema)


#: The kind of cache record (:mod:`miketalk.media.user_cache`) of a manifest's text that passed
#: the schema: the same text against the same schema passes again, so the next open of the
#: same model neither imports jsonschema nor validates (60 to 75 ms of every ``say``'s CPU,
#: before Festival starts).
VALID = "valid-manifests"


def _valid_key(text: str) -> list[str]:
    """What names a manifest's validation: the SHA-256 of its text and of the schema's."""
    import hashlib

    schema = resources.files("miketalk").joinpath("data/model_manifest.schema.json").read_bytes()
    return [hashlib.sha256(text.encode("utf-8")).hexdigest(), hashlib.sha256(schema).hexdigest()]


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
    path = check_inside(directory, Path(directory) / "manifest.json", "its manifest")
    if not path.is_file():
        raise MiketalkError(f"no model at {directory} (missing manifest.json)")
    try:
        text = path.read_text(encoding="utf-8")
        manifest = strict_json(text)
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise MiketalkError(f"cannot read model manifest {path}: {err}") from None
    if isinstance(manifest, dict) and manifest.get("format") != FORMAT:
        raise MiketalkError(
            f"{path} is not a {FORMAT} manifest (its format is {manifest.get('format')!r})"
        )
    valid = _valid_key(text)
    if read_record(VALID, *valid) is None:  # not yet validated in this form: validated now
        errors = sorted(_manifest_validator().iter_errors(manifest), key=lambda e: list(e.path))
        if errors:
            error = errors[0]
            where = "/".join(str(p) for p in error.absolute_path) or "the top level"
            raise MiketalkError(f"{path} is not a {FORMAT} manifest: at {where}, {error.message}")
        write_record(VALID, True, *valid)
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
    """``directory / relative``, for a path that stays inside ``directory``, its links
    resolved (:func:`check_inside`).

    Raises
    ------
    MiketalkError
        For an absolute path, a drive, a backslash, or a ``..`` component; for a link out
        of the directory, or what is not a regular file.
    """
    posix = PurePosixPath(relative)
    if posix.is_absolute() or ".." in posix.parts or "\\" in relative or ":" in relative:
        raise MiketalkError(
            f"{what}, {relative!r}, is outside the model directory {directory}: a manifest "
            "names files by paths relative to its directory, inside it"
        )
    return check_inside(directory, Path(directory) / posix, what)


def check_inside(
    directory: str | os.PathLike[str], path: str | os.PathLike[str], what: str
) -> Path:
    """``path``, when it is a file of the model in ``directory``: its real path (every link
    resolved) under the directory's real path and, when it exists, a regular file. The rule
    of every file read from a model (the page serves a model's picture by it too): a link to
    a system file in a model's folder is never read nor sent.

    Raises
    ------
    MiketalkError
        In one line naming ``path``, for a link that leaves the directory or a file that
        is not a regular file (a device, a FIFO, a directory).
    """
    root, real = os.path.realpath(directory), os.path.realpath(path)
    if os.path.commonpath([root, real]) != root:
        raise MiketalkError(
            f"{what}, {path}, is a link to a file outside the model directory {directory}: "
            "miketalk reads only the model's own files; rebuild the model"
        )
    try:
        mode = os.stat(real).st_mode
    except OSError:
        return Path(path)  # missing: said by whoever needs it
    if not stat.S_ISREG(mode):
        raise MiketalkError(
            f"{what}, {path}, is not a regular file: miketalk reads only the model's own files"
        )
    return Path(path)


def check_complete(flows: FlowDatabase, visemes: tuple[str, ...] | list[str]) -> None:
    """Raise MiketalkError naming the first missing pair file of ``visemes``."""
    for a, b in combinations(visemes, 2):
        path = flows.path_for(a, b)
        if not path.exists():
            raise MiketalkError(f"flow file {path} for visemes {a!r} and {b!r} is missing")


def file_entry(path: str | os.PathLike[str], *, in_parts: bool = False) -> dict:
    """What a manifest's ``files`` records of a file: ``{"size", "sha256"}``; for a file read
    in parts (``in_parts``, :data:`READ_IN_PARTS`) also ``block`` (:data:`BLOCK`) and
    ``blocks``, the SHA-256 of each block (one pass over the file)."""
    if not in_parts:
        return {"size": os.path.getsize(path), "sha256": file_digest(path)}
    import hashlib

    whole, blocks = hashlib.sha256(), []
    with open(path, "rb") as f:
        while data := f.read(BLOCK):
            whole.update(data)
            blocks.append(hashlib.sha256(data).hexdigest())
    size = os.path.getsize(path)
    return {"size": size, "sha256": whole.hexdigest(), "block": BLOCK, "blocks": blocks}


#: Files of a model checked at open by their size and header only, and by the SHA-256 of
#: each block a text reads when it reads it (:func:`check_parts`): the trained face's
#: patches, 178 to 897 MB in a built model, read memory-mapped, a few frames a sentence
#: (hashing them whole at every open would cost 0.5 to 1 s; docs/safety.md).
READ_IN_PARTS = ("trained/patches.npy",)

#: Bytes a block of a file read in parts (:data:`READ_IN_PARTS`) has its own SHA-256 for.
BLOCK = 1 << 20


def check_npy(path: Path) -> None:
    """Raise MiketalkError unless ``path`` is a ``.npy`` file whose header parses and whose
    size is its header's plus the bytes of the array it declares (nothing else is read)."""
    import numpy as np

    try:
        with open(path, "rb") as f:
            version = np.lib.format.read_magic(f)
            read_header = (
                np.lib.format.read_array_header_1_0
                if version == (1, 0)
                else np.lib.format.read_array_header_2_0
            )
            shape, _, dtype = read_header(f)
            expected = f.tell() + int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
            size = os.fstat(f.fileno()).st_size
    except (OSError, ValueError) as err:
        raise MiketalkError(
            f"model file {path} is not a whole .npy array ({err}): the model is damaged; rebuild it"
        ) from None
    if size != expected:
        raise MiketalkError(
            f"model file {path} is {size} bytes, its .npy header declares {expected} "
            f"({'x'.join(map(str, shape))} {dtype}): the model is damaged; rebuild it"
        )


def check_parts(
    directory: str | os.PathLike[str], manifest: dict, relative: str, spans: Sequence
) -> int:
    """Check the blocks of a file read in parts (:data:`READ_IN_PARTS`) that hold the byte
    ``spans`` (``(start, stop)`` pairs) against their SHA-256 in the manifest, before they
    are used. A model written before blocks were recorded is not checked.

    Returns
    -------
    int
        The number of blocks checked.

    Raises
    ------
    MiketalkError
        In one line naming the file, for a block that does not match.
    """
    import hashlib

    entry = manifest.get("files", {}).get(relative)
    if not entry or "blocks" not in entry:
        return 0
    block, digests = int(entry["block"]), entry["blocks"]
    wanted = sorted({i for a, b in spans for i in range(a // block, (b - 1) // block + 1)})
    path = inside(directory, relative, "a file of the manifest")
    try:
        with open(path, "rb") as f:
            for i in wanted:
                f.seek(i * block)
                if i >= len(digests) or hashlib.sha256(f.read(block)).hexdigest() != digests[i]:
                    raise MiketalkError(
                        f"model file {path} does not match its checksum in the manifest (its "
                        f"bytes {i * block} to {(i + 1) * block}): the model is damaged; "
                        "rebuild it"
                    )
    except OSError as err:
        raise MiketalkError(f"model file {path} cannot be read ({err.strerror or err})") from None
    return len(wanted)


#: Threads hashing a model's files when it opens (SHA-256 in C, without the GIL).
DIGEST_THREADS = max(1, min(2, os.cpu_count() or 1))


def files_stat(directory: str | os.PathLike[str], manifest: dict) -> tuple:
    """``(name, size, mtime_ns, ctime_ns, inode)`` of each file the manifest's ``files``
    lists (None for one that cannot be read): what tells a model kept open that a file
    changed since (any write to a file or its times moves its ctime, which no one sets)."""
    stats = []
    for relative in sorted(manifest.get("files", {})):
        try:
            st = os.stat(inside(directory, relative, "a file of the manifest"))
        except OSError:
            stats.append((relative, None))
        else:
            stats.append((relative, st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino))
    return tuple(stats)


#: The models whose files :func:`checked_files` found whole in this process: their
#: directory, manifest and flow files' stat, and the files' :func:`files_stat`.
_CHECKED: dict[tuple, tuple] = {}

#: The kind of record (:mod:`miketalk.media.user_cache`) a model's passed check is kept as.
RECORDS = "checked-models"

#: At most this many models are remembered (the oldest forgotten first).
CHECKED_MODELS = 32

#: How long before its check a model's files must have last changed for it to be
#: remembered by :func:`checked_files` (ns).
SETTLED_NS = 2_000_000_000


def _plain(value: Any) -> Any:
    """``value`` as JSON reads it back (tuples as lists): a record compared with a state."""
    return json.loads(json.dumps(value))


def _unlisted_stat(
    directory: str | os.PathLike[str], flows: FlowDatabase, visemes: Sequence[str]
) -> tuple:
    """The stat of the files :func:`check_files` reads beyond those the manifest lists: the
    flow files and the files read in parts (``()`` when a flow file is missing)."""
    out = []
    for a, b in combinations(visemes, 2):
        try:
            st = os.stat(flows.path_for(a, b))
        except OSError:
            return ()  # a flow file missing: never remembered, always checked
        out.append((st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino))
    for relative in READ_IN_PARTS:
        try:
            st = os.stat(inside(directory, relative, "a file of the model"))
        except OSError:
            out.append(None)
        else:
            out.append((st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino))
    return tuple(out)


def checked_files(
    directory: str | os.PathLike[str], manifest: dict, flows: FlowDatabase, visemes: Sequence[str]
) -> tuple:
    """:func:`check_files`, once per unchanged model, in a process and across runs.

    A model whose manifest, flow files, files read in parts and listed files all have the
    size, modification and change times and inode they had when :func:`check_files` last
    passed them is not hashed again (opening it again then costs its images, not its
    checksums); any change to any of them, or to the manifest's text (every file's size and
    SHA-256), checks it all again. What passed is remembered in this process and in the
    user's cache (:mod:`miketalk.media.user_cache`, kind :data:`RECORDS`, keyed by the
    model's real path and its manifest's text), so the next ``miketalk say`` of the same
    model does not hash it again either (s1: 0.6 s of every command before).
    A model with a file changed less than :data:`SETTLED_NS` before its check is not
    remembered: a file's times are kept to the kernel's clock tick, so a change within
    the same tick as the write before it would not show (git's "racily clean" entries).

    Returns
    -------
    tuple
        The files' :func:`files_stat`.
    """
    started = time.time_ns()
    try:
        st = os.stat(Path(directory) / "manifest.json")
    except OSError:
        return check_files(directory, manifest, flows, visemes)
    unlisted = _unlisted_stat(directory, flows, visemes)
    stat = files_stat(directory, manifest)
    manifest_stat = (st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino)
    key = (os.path.realpath(directory), json.dumps(manifest, sort_keys=True), tuple(visemes))
    state = (manifest_stat, unlisted, stat)
    if unlisted and _CHECKED.get(key) == state:
        return stat
    if unlisted and _plain(read_record(RECORDS, *key)) == _plain(state):  # another run's check
        _CHECKED[key] = state
        return stat
    checked = check_files(directory, manifest, flows, visemes)
    times = [*manifest_stat[1:3]]
    times += [t for item in unlisted if item for t in item[1:3]]  # (size, mtime, ctime, ino)
    times += [t for item in stat if item[1] is not None for t in item[2:4]]  # (name, size, ...)
    settled = max(times) < started - SETTLED_NS
    _CHECKED.pop(key, None)
    if unlisted and checked == stat and settled:
        _CHECKED[key] = state
        while len(_CHECKED) > CHECKED_MODELS:
            _CHECKED.pop(next(iter(_CHECKED)))
        write_record(RECORDS, state, *key)
    return checked


def check_files(
    directory: str | os.PathLike[str], manifest: dict, flows: FlowDatabase, visemes: Sequence[str]
) -> tuple:
    """Check, when a model is opened, that every file it needs is there and whole.

    Every flow file of ``visemes`` exists, and is a whole OpenEXR file (its header and
    chunk table, :func:`miketalk.flow.exr.check_flow_file`); every file the manifest's
    ``files`` lists (a model written since checksums were recorded: its viseme images and
    flow files; since 2026-11-27 also its coarticulation, trained face and background)
    exists, has its size there, and its SHA-256: all of them, not only those a text's
    transitions read (docs/safety.md has the cost). A file read in parts
    (:data:`READ_IN_PARTS`, the trained face's patches) is checked here by its size and
    its ``.npy`` header (:func:`check_npy`), and its blocks by :func:`check_parts` when
    they are read.

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
    files = manifest.get("files", {})
    for relative in READ_IN_PARTS:  # a model written before they were listed: their header
        path = inside(directory, relative, "a file of the model")
        if relative not in files and path.is_file():
            check_npy(path)
    for relative, entry in sorted(files.items()):
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
        if "blocks" in entry:  # read in parts: hashed block by block as it is read
            if path.suffix == ".npy":
                check_npy(path)
            continue
        listed.append((path, entry["sha256"]))
    for a, b in combinations(visemes, 2):
        check_flow_file(check_inside(directory, flows.path_for(a, b), "a flow file"))

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
