"""Ground-truth optical flow between two poses of the face, with its validity mask.

For every pixel centre of image A we find the visible triangle and the perspective-correct
barycentric coordinates of the surface point seen there (:mod:`synth_face.raster`). Because
the deformation is per-vertex and the texture is interpolated with the same barycentrics, the
same barycentrics in the same triangle of pose B are the same material point; projecting it
with the same camera gives its position ``q`` in image B. The point is hidden in B when a
triangle of B covers ``q`` (exactly, at sub-pixel precision) and is nearer than the point by
more than ``depth_tol``. The candidate occluders are the triangles B's z-buffer shows at the
four pixel centres around ``q``. A point is also hidden when all four of those pixel centres
show surfaces nearer than it: the occluder may be a sliver no pixel centre samples (the
lips' triangles along their contact line).
"""

from __future__ import annotations

import numpy as np

from synth_face.camera import Camera
from synth_face.raster import rasterize

#: Two surfaces closer than this along the line of sight (mm) count as the same surface.
DEPTH_TOL_MM = 0.3


def _cover_depth(proj: np.ndarray, tri_vertices: np.ndarray, col: np.ndarray, row: np.ndarray):
    """Depth at ``(col, row)`` of each projected triangle, ``inf`` where it does not cover it."""
    p0, p1, p2 = (proj[tri_vertices[:, i]] for i in range(3))
    area = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p2[:, 0] - p0[:, 0]) * (
        p1[:, 1] - p0[:, 1]
    )
    ok = area != 0.0
    area = np.where(ok, area, 1.0)
    l0 = ((p1[:, 0] - col) * (p2[:, 1] - row) - (p2[:, 0] - col) * (p1[:, 1] - row)) / area
    l1 = ((p2[:, 0] - col) * (p0[:, 1] - row) - (p0[:, 0] - col) * (p2[:, 1] - row)) / area
    l2 = 1.0 - l0 - l1
    eps = -1e-9
    ok &= (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
    inv = l0 / p0[:, 2] + l1 / p1[:, 2] + l2 / p2[:, 2]
    ok &= inv > 0.0
    return np.where(ok, 1.0 / np.where(ok, inv, 1.0), np.inf)


def true_flow(
    camera: Camera,
    triangles: np.ndarray,
    verts_a: np.ndarray,
    verts_b: np.ndarray,
    *,
    depth_tol: float = DEPTH_TOL_MM,
) -> tuple[np.ndarray, np.ndarray]:
    """True flow from the image of mesh A to the image of mesh B (same topology).

    Parameters
    ----------
    camera : Camera
        The camera both images are seen through.
    triangles : ndarray, shape (T, 3)
        The shared triangles.
    verts_a, verts_b : ndarray, shape (N, 3)
        World vertex positions in A and in B (mm).
    depth_tol : float
        Depth tolerance of the visibility test (mm).

    Returns
    -------
    flow : ndarray, shape (H, W, 2) float32
        ``flow[..., 0]`` = dx (columns), ``flow[..., 1]`` = dy (rows), from each pixel of A
        to its surface point's position in B; zero where invalid.
    valid : ndarray, shape (H, W) bool
        True where A shows the face and the point is inside B's frame and not hidden there.
    """
    n = camera.size
    proj_a = camera.project(verts_a)
    proj_b = camera.project(verts_b)
    ra = rasterize(proj_a, triangles, n)
    hit = ra.tri >= 0
    rows, cols = np.nonzero(hit)
    tri = ra.tri[hit]
    bary = ra.bary[hit]
    tv = triangles[tri]
    # The material point under each pixel of A, carried to pose B and projected.
    pt_b = np.einsum("ki,kij->kj", bary, verts_b[tv])
    q = camera.project(pt_b)
    dx = q[:, 0] - cols
    dy = q[:, 1] - rows

    # Visibility in B: is q covered by a nearer triangle among those B's z-buffer shows at
    # the four pixel centres around it?
    rb = rasterize(proj_b, triangles, n)
    inside = (q[:, 0] >= -0.5) & (q[:, 0] <= n - 0.5) & (q[:, 1] >= -0.5) & (q[:, 1] <= n - 0.5)
    c0 = np.floor(q[:, 0]).astype(np.int64)
    r0 = np.floor(q[:, 1]).astype(np.int64)
    covered = np.zeros(q.shape[0], dtype=bool)
    all_nearer = np.ones(q.shape[0], dtype=bool)
    for dr, dc in ((0, 0), (0, 1), (1, 0), (1, 1)):
        rr, cc = np.clip(r0 + dr, 0, n - 1), np.clip(c0 + dc, 0, n - 1)
        on_image = (r0 + dr >= 0) & (r0 + dr < n) & (c0 + dc >= 0) & (c0 + dc < n)
        tb = np.where(on_image, rb.tri[rr, cc], -1)
        zb = _cover_depth(proj_b, triangles[np.maximum(tb, 0)], q[:, 0], q[:, 1])
        covered |= (tb >= 0) & (zb < q[:, 2] - depth_tol)
        all_nearer &= (tb >= 0) & (rb.depth[rr, cc] < q[:, 2] - depth_tol)
    # A surface in front may be thinner than a pixel where it folds (the lips' contact):
    # then no pixel centre samples it, but all four show nearer surfaces around the point.
    ok = inside & ~covered & ~all_nearer

    flow = np.zeros((n, n, 2), dtype=np.float32)
    valid = np.zeros((n, n), dtype=bool)
    flow[rows[ok], cols[ok], 0] = dx[ok]
    flow[rows[ok], cols[ok], 1] = dy[ok]
    valid[rows[ok], cols[ok]] = True
    return flow, valid
