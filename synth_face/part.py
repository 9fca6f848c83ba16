"""One rigid-topology piece of the face (skin, teeth, tongue, cavity): geometry + look."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Material:
    """Phong coefficients of a part (VTK's ambient / diffuse / specular)."""

    ambient: float = 0.3
    diffuse: float = 0.7
    specular: float = 0.0
    specular_power: float = 10.0


@dataclass(frozen=True, eq=False)
class Part:
    """A triangle mesh at rest, with texture coordinates and per-vertex attributes.

    Attributes
    ----------
    name : str
        ``skin``, ``upper_teeth``, ``lower_teeth``, ``tongue`` or ``cavity``.
    rest : ndarray, shape (n, 3) float64
        Rest positions (mm).
    triangles : ndarray, shape (m, 3) int64
        Vertex indices local to the part.
    uv : ndarray, shape (n, 2) float64
        Texture coordinates in [0, 1] (v up, as OpenGL has it).
    texture : ndarray, shape (h, w, 3) uint8
        The part's texture image, top row first.
    material : Material
        Shading coefficients.
    attrs : dict of str to ndarray
        Per-vertex values the blendshapes are defined from (part specific).
    """

    name: str
    rest: np.ndarray
    triangles: np.ndarray
    uv: np.ndarray
    texture: np.ndarray
    material: Material
    attrs: dict[str, np.ndarray] = field(default_factory=dict)


def grid_triangles(rows: int, cols: int, *, wrap: bool) -> np.ndarray:
    """Triangles of a ``rows x cols`` vertex grid (row-major), optionally closed across columns.

    Each quad is split along the diagonal from its top-left to its bottom-right corner.
    """
    ncol = cols if wrap else cols - 1
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(ncol), indexing="ij")
    c1 = (c + 1) % cols
    a = r * cols + c
    b = r * cols + c1
    d = (r + 1) * cols + c
    e = (r + 1) * cols + c1
    t1 = np.stack([a, d, e], axis=-1).reshape(-1, 3)
    t2 = np.stack([a, e, b], axis=-1).reshape(-1, 3)
    return np.concatenate([t1, t2]).astype(np.int64)
