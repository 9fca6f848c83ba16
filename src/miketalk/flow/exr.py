"""One flow-database file: both flows of a viseme pair in a 32-bit float OpenEXR.

Layout (a single-part scanline EXR, uncompressed)
-------------------------------------------------
Channels
    ``forward.u``, ``forward.v``: FLOAT, the flow from ``source`` to ``target``
    (the paper's C_0, Eq. 1): ``u`` = dx (columns), ``v`` = dy (rows), so
    ``source(p) ~ target(p + (u, v))``.
    ``backward.u``, ``backward.v``: FLOAT, the flow from ``target`` to ``source`` (C_1, Eq. 2).
    ``forward.valid``, ``backward.valid``: optional UINT, 1 where the flow is
    known (ground-truth flows with occlusions), 0 elsewhere.
Header attributes (strings)
    ``miketalk.source``, ``miketalk.target``: the viseme names, as given.
    ``miketalk.estimator``: the registry name of the estimator (or e.g. ``ground_truth``).
    ``miketalk.settings``: the estimator's settings as a JSON object.
    ``miketalk.convention``: the sentence above, for readers without this code.
    ``miketalk.format``: ``miketalk-flow-pair 1``.

No compression: lossless ZIP saved 2% on estimated flows (full-precision floats
are noise to it) and made each 256^2 file 3.5 times slower to write (22 ms vs
6 ms) and twice as slow to read; ZSTD saved 20% at the same cost as ZIP.
Any reader handles either.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import OpenEXR

from miketalk.checks import check_flow
from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_path

FORMAT = "miketalk-flow-pair 1"
CONVENTION = (
    "forward = flow from source to target: source(x, y) ~ target(x + u, y + v), "
    "u along columns, v along rows, in pixels; backward = flow from target to source"
)
LAYERS = ("forward", "backward")
_ATTRIBUTES = ("source", "target", "estimator", "settings")


@dataclass(frozen=True)
class FlowPair:
    """The contents of one flow-pair file.

    Attributes
    ----------
    source, target : str
        Viseme names; ``forward`` goes from ``source`` to ``target``.
    forward, backward : ndarray, shape (H, W, 2), float32
        The two flows.
    estimator : str
        Name of the estimator that made them.
    settings : dict
        Its settings.
    valid_forward, valid_backward : ndarray of bool, shape (H, W), or None
        Where each flow is known, if the file says.
    """

    source: str
    target: str
    forward: np.ndarray
    backward: np.ndarray
    estimator: str
    settings: dict[str, Any]
    valid_forward: np.ndarray | None = None
    valid_backward: np.ndarray | None = None


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, tuple | set | np.ndarray):
        return list(value)
    raise TypeError(f"setting value {value!r} is not JSON-serialisable")


def write_flow_pair(
    path: str | os.PathLike[str],
    forward: np.ndarray,
    backward: np.ndarray,
    *,
    source: str,
    target: str,
    estimator: str,
    settings: Mapping[str, Any] | None = None,
    valid: tuple[np.ndarray, np.ndarray] | None = None,
) -> Path:
    """Write the two flows of a viseme pair to one OpenEXR file, atomically.

    Parameters
    ----------
    path : path-like
        The file to write; :func:`miketalk.flow.database.pair_path` gives the
        database's name for a pair.
    forward : ndarray, shape (H, W, 2)
        Flow from ``source`` to ``target``.
    backward : ndarray, shape (H, W, 2)
        Flow from ``target`` to ``source``.
    source, target : str
        Viseme names (any text; recorded in the header).
    estimator : str
        The estimator's registry name.
    settings : mapping, optional
        The estimator's settings; stored as JSON.
    valid : (ndarray, ndarray) of bool, optional
        Masks of known flow for ``forward`` and ``backward`` (ground truth).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    MiketalkError
        For flows that are not finite ``(H, W, 2)`` fields of one size, bad
        masks, or settings that are not JSON-serialisable.
    """
    forward = check_flow(forward, "forward")
    backward = check_flow(backward, "backward", forward.shape[:2])
    for name, value in (("source", source), ("target", target), ("estimator", estimator)):
        if not isinstance(value, str) or not value:
            raise MiketalkError(f"{name} must be a non-empty string, got {value!r}")
    try:
        settings_json = json.dumps(dict(settings or {}), sort_keys=True, default=_json_default)
    except (TypeError, ValueError) as err:
        raise MiketalkError(f"settings cannot be stored as JSON: {err}") from err
    channels: dict[str, np.ndarray] = {}
    for layer, flow in zip(LAYERS, (forward, backward), strict=True):
        channels[f"{layer}.u"] = np.ascontiguousarray(flow[..., 0])
        channels[f"{layer}.v"] = np.ascontiguousarray(flow[..., 1])
    if valid is not None:
        if len(valid) != 2:
            raise MiketalkError("valid must be a pair (valid_forward, valid_backward)")
        for layer, mask in zip(LAYERS, valid, strict=True):
            mask = np.asarray(mask)
            if mask.shape != forward.shape[:2] or mask.dtype != bool:
                raise MiketalkError(
                    f"valid mask for {layer} must be boolean {forward.shape[:2]}, "
                    f"got {mask.dtype} {mask.shape}"
                )
            channels[f"{layer}.valid"] = mask.astype(np.uint32)
    header = {
        "compression": OpenEXR.NO_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "miketalk.format": FORMAT,
        "miketalk.convention": CONVENTION,
        "miketalk.source": source,
        "miketalk.target": target,
        "miketalk.estimator": estimator,
        "miketalk.settings": settings_json,
    }
    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            OpenEXR.File(header, channels).write(str(tmp))
    except (OSError, RuntimeError) as err:
        raise MiketalkError(f"cannot write flow file {path}: {err}") from err
    return path


def read_flow_header(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The miketalk attributes of a flow file without reading its pixels.

    Returns
    -------
    dict
        ``source``, ``target``, ``estimator`` (str) and ``settings`` (dict).

    Raises
    ------
    MiketalkError
        As :func:`read_flow_pair`, for a missing or unreadable file or a missing
        attribute.
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"flow file {path} does not exist; compute the flow database first")
    try:
        header = OpenEXR.File(str(path), header_only=True).header()
    except Exception as err:
        raise MiketalkError(f"flow file {path} is not a readable OpenEXR file: {err}") from err
    attrs, settings = _attributes(path, header)
    return {**attrs, "settings": settings}


def _attributes(path: Path, header: dict) -> tuple[dict[str, str], dict]:
    """The checked ``miketalk.*`` header attributes and the decoded settings."""
    attrs = {}
    for key in _ATTRIBUTES:
        value = header.get(f"miketalk.{key}")
        if not isinstance(value, str):
            raise MiketalkError(
                f"flow file {path} lacks the header attribute miketalk.{key}; "
                "it was not written by miketalk.flow.write_flow_pair"
            )
        attrs[key] = value
    try:
        settings = json.loads(attrs["settings"])
    except json.JSONDecodeError as err:
        raise MiketalkError(f"flow file {path}: miketalk.settings is not JSON: {err}") from err
    return attrs, settings


def read_flow_pair(path: str | os.PathLike[str]) -> FlowPair:
    """Read a file written by :func:`write_flow_pair`, checking it.

    Raises
    ------
    MiketalkError
        Naming the file if it is missing, not a readable EXR, lacks a channel
        or attribute, or holds NaN/inf flow values.
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"flow file {path} does not exist; compute the flow database first")
    try:
        exr = OpenEXR.File(str(path), separate_channels=True)
        header = exr.header()
        channels = {name: ch.pixels for name, ch in exr.channels().items()}
    except Exception as err:  # OpenEXR raises RuntimeError and others for bad files
        raise MiketalkError(f"flow file {path} is not a readable OpenEXR file: {err}") from err
    attrs, settings = _attributes(path, header)
    flows = {}
    for layer in LAYERS:
        parts = []
        for comp in ("u", "v"):
            pixels = channels.get(f"{layer}.{comp}")
            if pixels is None:
                raise MiketalkError(
                    f"flow file {path} lacks channel {layer}.{comp} "
                    f"(has {', '.join(sorted(channels))})"
                )
            if not np.issubdtype(pixels.dtype, np.floating):
                raise MiketalkError(f"flow file {path}: channel {layer}.{comp} is not float")
            parts.append(pixels.astype(np.float32, copy=False))
        flow = np.stack(parts, axis=-1)
        if not np.isfinite(flow).all():
            raise MiketalkError(f"flow file {path}: the {layer} flow holds NaN or inf values")
        flows[layer] = flow
    masks = {layer: channels.get(f"{layer}.valid") for layer in LAYERS}
    return FlowPair(
        source=attrs["source"],
        target=attrs["target"],
        forward=flows["forward"],
        backward=flows["backward"],
        estimator=attrs["estimator"],
        settings=settings,
        valid_forward=None if masks["forward"] is None else masks["forward"] != 0,
        valid_backward=None if masks["backward"] is None else masks["backward"] != 0,
    )


#: Scanlines per chunk of each OpenEXR compression (by its code in the header).
_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}
_EXR_MAGIC = 20000630


def check_flow_file(path: str | os.PathLike[str]) -> None:
    """Check, without decoding its pixels, that a flow file is a whole OpenEXR file.

    Its header is parsed and, for a scanline file, its chunk table: every chunk must lie
    inside the file, so a truncated file (a copy cut short, a full disk) is found when a
    model is opened rather than when that transition is drawn. A few kB are read.

    Raises
    ------
    MiketalkError
        Naming the file: missing, not OpenEXR, or cut short.
    """
    import struct

    path = Path(path)

    def bad(why: str) -> MiketalkError:
        return MiketalkError(f"flow file {path} {why}: the model is damaged; rebuild it")

    try:
        size = path.stat().st_size
        with path.open("rb") as f:
            head = f.read(1 << 16)
            if len(head) < 8 or struct.unpack("<i", head[:4])[0] != _EXR_MAGIC:
                raise bad("is not an OpenEXR file")
            if head[5] & 0x1E:  # tiled, deep or multi-part: the header alone is checked
                return
            at, attributes = 8, {}
            while True:
                end = head.index(b"\0", at)
                name = head[at:end].decode("latin-1")
                if not name:
                    at = end + 1
                    break
                kind_end = head.index(b"\0", end + 1)
                (length,) = struct.unpack("<i", head[kind_end + 1 : kind_end + 5])
                attributes[name] = head[kind_end + 5 : kind_end + 5 + length]
                at = kind_end + 5 + length
                if at > len(head):
                    raise ValueError("header past its block")
            y_min, y_max = struct.unpack("<4i", attributes["dataWindow"])[1::2]
            lines = _LINES_PER_CHUNK.get(attributes["compression"][0], 1)
            chunks = -(-(y_max - y_min + 1) // lines)
            f.seek(at)
            table = f.read(8 * chunks)
            if len(table) < 8 * chunks:
                raise bad(f"is cut short ({size} bytes: its chunk table is incomplete)")
            last = max(struct.unpack(f"<{chunks}Q", table))
            f.seek(last)
            chunk = f.read(8)
            if len(chunk) < 8:
                raise bad(f"is cut short ({size} bytes, its last chunk starts at {last})")
            (length,) = struct.unpack("<i", chunk[4:])
            if last + 8 + length > size:
                raise bad(
                    f"is cut short ({size} bytes, its last chunk ends at {last + 8 + length})"
                )
    except FileNotFoundError:
        raise MiketalkError(
            f"flow file {path} is missing: the model is damaged; rebuild it"
        ) from None
    except OSError as err:
        raise bad(f"cannot be read ({err.strerror or err})") from None
    except (ValueError, KeyError, IndexError, struct.error):
        raise bad("has a malformed OpenEXR header") from None
