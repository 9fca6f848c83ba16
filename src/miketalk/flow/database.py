"""The flow database: one OpenEXR file per unordered viseme pair, and its reader.

For the 16 visemes the morphs need the flow in both directions between every
two of them (the paper's C_0 and C_1, section 5.1): 120 files, each holding
both directions (see :mod:`miketalk.flow.exr` for the layout).

File names
----------
Viseme names hold characters that are awkward in file names (``#``, ``@``,
``-`` at the start, upper case on case-insensitive disks).
:func:`miketalk.visemes.viseme_slug`
keeps ``a-z``, ``0-9`` and inner ``-`` and writes every other character as
``_`` plus the two hex digits of each of its UTF-8 bytes: ``#`` becomes
``_23``, ``w-au`` stays ``w-au``, ``@`` becomes ``_40``. The map is
one-to-one, and a slug never contains ``__``, so the pair file
``{slug(first)}__{slug(second)}.exr`` names one pair, with ``first`` the
smaller name in Python string order. The header records the real names and
which way ``forward`` goes, so the file name is only an address.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.flow.exr import FlowPair, read_flow_pair
from miketalk.visemes import viseme_slug

SUFFIX = ".exr"


def pair_filename(a: str, b: str) -> str:
    """The file name of the unordered pair ``{a, b}``: the same for ``(a, b)`` and ``(b, a)``.

    Examples
    --------
    >>> pair_filename("p", "#") == pair_filename("#", "p") == "_23__p.exr"
    True
    """
    if a == b:
        raise MiketalkError(f"a flow pair needs two different visemes, got {a!r} twice")
    first, second = sorted((a, b))
    return f"{viseme_slug(first)}__{viseme_slug(second)}{SUFFIX}"


def pair_path(directory: str | os.PathLike[str], a: str, b: str) -> Path:
    """``directory / pair_filename(a, b)``."""
    return Path(directory) / pair_filename(a, b)


class FlowDatabase:
    """Read flows between visemes from a directory of pair files.

    Parameters
    ----------
    directory : path-like
        Where the pair files are (named by :func:`pair_filename`).
    cache_size : int
        How many pair files to keep in memory (least recently used dropped).

    Examples
    --------
    >>> db = FlowDatabase("results/flows")          # doctest: +SKIP
    >>> c0 = db.flow("p", "ii")   # p(x) ~ ii(x + c0(x))  # doctest: +SKIP
    """

    def __init__(self, directory: str | os.PathLike[str], *, cache_size: int = 128) -> None:
        self.directory = Path(directory)
        if not self.directory.is_dir():
            raise MiketalkError(f"flow database directory {self.directory} does not exist")
        if cache_size < 1:
            raise MiketalkError(f"cache_size must be >= 1, got {cache_size!r}")
        self.cache_size = cache_size
        self._cache: OrderedDict[Path, FlowPair] = OrderedDict()

    def path_for(self, a: str, b: str) -> Path:
        """The file holding the flows between ``a`` and ``b``."""
        return pair_path(self.directory, a, b)

    def pair(self, a: str, b: str) -> FlowPair:
        """The checked contents of the file of ``{a, b}`` (cached; arrays read-only).

        Raises
        ------
        MiketalkError
            Naming the file if it is missing or corrupt, or if its header names
            another pair.
        """
        path = self.path_for(a, b)
        pair = self._cache.get(path)
        if pair is not None:
            self._cache.move_to_end(path)
            return pair
        pair = read_flow_pair(path)
        if {pair.source, pair.target} != {a, b}:
            raise MiketalkError(
                f"flow file {path} holds the pair ({pair.source!r}, {pair.target!r}), "
                f"not ({a!r}, {b!r}); it was renamed or written under the wrong name"
            )
        for array in (pair.forward, pair.backward, pair.valid_forward, pair.valid_backward):
            if array is not None:
                array.flags.writeable = False
        self._cache[path] = pair
        if len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return pair

    def flow(self, a: str, b: str) -> np.ndarray:
        """The flow from viseme ``a`` to viseme ``b``: ``a(p) ~ b(p + flow(p))``.

        Reads the file of the unordered pair and returns its ``forward`` layer
        if the file's source is ``a``, else its ``backward`` layer. ``flow(a, a)``
        is zero, sized like the files of ``a``.

        Returns
        -------
        ndarray, shape (H, W, 2), float32, read-only
            Copy it before changing it.

        Raises
        ------
        MiketalkError
            If the file is missing or corrupt (naming it).
        """
        if a == b:
            return self._zero_flow(a)
        pair = self.pair(a, b)
        return pair.forward if pair.source == a else pair.backward

    def _zero_flow(self, a: str) -> np.ndarray:
        name = viseme_slug(a)
        files = sorted(self.directory.glob(f"{name}__*{SUFFIX}"))
        files += sorted(self.directory.glob(f"*__{name}{SUFFIX}"))
        if not files:
            raise MiketalkError(f"flow database {self.directory} has no file for viseme {a!r}")
        pair = read_flow_pair(files[0])
        zero = np.zeros_like(pair.forward)
        zero.flags.writeable = False
        return zero

    def valid(self, a: str, b: str) -> np.ndarray | None:
        """Where the flow from ``a`` to ``b`` is known (ground truth files); None if not stored."""
        pair = self.pair(a, b)
        return pair.valid_forward if pair.source == a else pair.valid_backward
