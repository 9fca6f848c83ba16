"""A z-buffer rasteriser for geometry: which triangle, and where on it, each pixel sees.

The renderer draws pixels with OpenGL; the true flow needs, for every pixel centre, the
visible triangle and the perspective-correct barycentric coordinates of the surface point
hit there. We compute them here from the same camera, so the flow never depends on reading
OpenGL buffers back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class Raster:
    """Per-pixel visibility of a projected mesh.

    Attributes
    ----------
    tri : ndarray, shape (H, W) int32
        Index of the visible triangle, -1 on the background.
    bary : ndarray, shape (H, W, 3) float64
        Perspective-correct barycentric coordinates of the visible surface point
        (zero on the background).
    depth : ndarray, shape (H, W) float64
        Its distance along the optical axis (mm; ``inf`` on the background).
    """

    tri: np.ndarray
    bary: np.ndarray
    depth: np.ndarray


@numba.njit(cache=True, nogil=True)
def _rasterize(px, tris, h, w, tri_id, bary, depth):  # pragma: no cover - compiled
    for t in range(tris.shape[0]):
        i0, i1, i2 = tris[t, 0], tris[t, 1], tris[t, 2]
        x0, y0, z0 = px[i0, 0], px[i0, 1], px[i0, 2]
        x1, y1, z1 = px[i1, 0], px[i1, 1], px[i1, 2]
        x2, y2, z2 = px[i2, 0], px[i2, 1], px[i2, 2]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if area == 0.0 or z0 <= 0.0 or z1 <= 0.0 or z2 <= 0.0:
            continue
        inv_area = 1.0 / area
        cmin = max(int(np.ceil(min(x0, x1, x2))), 0)
        cmax = min(int(np.floor(max(x0, x1, x2))), w - 1)
        rmin = max(int(np.ceil(min(y0, y1, y2))), 0)
        rmax = min(int(np.floor(max(y0, y1, y2))), h - 1)
        for r in range(rmin, rmax + 1):
            for c in range(cmin, cmax + 1):
                # Screen-space barycentrics: signed sub-triangle areas over the whole.
                l0 = ((x1 - c) * (y2 - r) - (x2 - c) * (y1 - r)) * inv_area
                l1 = ((x2 - c) * (y0 - r) - (x0 - c) * (y2 - r)) * inv_area
                l2 = 1.0 - l0 - l1
                if l0 < 0.0 or l1 < 0.0 or l2 < 0.0:
                    continue
                # 1/depth is affine in screen space; weights l_i / z_i are perspective-correct.
                iz = l0 / z0 + l1 / z1 + l2 / z2
                z = 1.0 / iz
                if z < depth[r, c]:
                    depth[r, c] = z
                    tri_id[r, c] = t
                    bary[r, c, 0] = l0 / z0 * z
                    bary[r, c, 1] = l1 / z1 * z
                    bary[r, c, 2] = l2 / z2 * z


def rasterize(projected: np.ndarray, triangles: np.ndarray, size: int) -> Raster:
    """Rasterise projected triangles at the pixel centres.

    Parameters
    ----------
    projected : ndarray, shape (N, 3)
        ``(col, row, depth)`` of every vertex, from :meth:`Camera.project`.
    triangles : ndarray, shape (T, 3) int
        Vertex indices.
    size : int
        Image width and height.

    Returns
    -------
    Raster
        The nearest triangle at every pixel centre, with its barycentrics and depth.
    """
    tri = np.full((size, size), -1, dtype=np.int32)
    bary = np.zeros((size, size, 3), dtype=np.float64)
    depth = np.full((size, size), np.inf, dtype=np.float64)
    _rasterize(
        np.ascontiguousarray(projected, dtype=np.float64),
        np.ascontiguousarray(triangles, dtype=np.int64),
        size,
        size,
        tri,
        bary,
        depth,
    )
    return Raster(tri=tri, bary=bary, depth=depth)
