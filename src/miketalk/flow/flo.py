"""Middlebury ``.flo`` files, for exchanging flows with other tools.

Format (little-endian): float32 magic ``202021.25`` (the bytes ``PIEH``),
int32 width, int32 height, then ``height * width`` pairs of float32 ``(u, v)``
row by row, ``u`` = dx and ``v`` = dy: our ``(H, W, 2)`` layout exactly.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from miketalk.checks import check_flow
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_bytes_atomic

MAGIC = np.float32(202021.25)
_HEADER = np.dtype([("magic", "<f4"), ("width", "<i4"), ("height", "<i4")])


def write_flo(path: str | os.PathLike[str], flow: np.ndarray) -> Path:
    """Write ``flow`` (H, W, 2) to a Middlebury ``.flo`` file, atomically.

    Raises
    ------
    MiketalkError
        If ``flow`` is not a finite ``(H, W, 2)`` field.
    """
    flow = check_flow(flow, "flow")
    h, w = flow.shape[:2]
    header = np.array([(MAGIC, w, h)], dtype=_HEADER)
    path = Path(path)
    write_bytes_atomic(path, header.tobytes() + flow.astype("<f4").tobytes())
    return path


def read_flo(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a Middlebury ``.flo`` file into an ``(H, W, 2)`` float32 array.

    Raises
    ------
    MiketalkError
        Naming the file if it is missing, has the wrong magic number, or its
        size does not match its header.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise MiketalkError(f"cannot read flow file {path}: {err.strerror}") from err
    if len(data) < _HEADER.itemsize:
        raise MiketalkError(f"flow file {path} is too short to be a .flo file")
    header = np.frombuffer(data, _HEADER, count=1)[0]
    if header["magic"] != MAGIC:
        raise MiketalkError(f"flow file {path} is not a .flo file (bad magic number)")
    w, h = int(header["width"]), int(header["height"])
    expected = _HEADER.itemsize + 8 * w * h
    if w < 1 or h < 1 or len(data) != expected:
        raise MiketalkError(
            f"flow file {path} is {len(data)} bytes, but its header ({w}x{h}) needs {expected}"
        )
    flow = np.frombuffer(data, "<f4", offset=_HEADER.itemsize).reshape(h, w, 2)
    return flow.astype(np.float32)
