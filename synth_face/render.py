"""Off-screen rendering of the face with pyvista/VTK, plus its ground truth.

The scene (meshes, textures, lights, camera) is built once; each frame only rewrites vertex
positions and normals in place and re-renders. Multi-sampling and every other anti-aliasing
option are off, so a pixel shows exactly one surface and the same parameters give the same
bytes.
"""

from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numba
import numpy as np
import pyvista as pv
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

from miketalk.errors import MiketalkError
from synth_face.camera import Camera, apply_transform
from synth_face.face import Face
from synth_face.flow import true_flow
from synth_face.mask import mouth_mask
from synth_face.part import Material

#: Background colour (RGB in [0, 1]): a dark blue-grey wall.
BACKGROUND = (0.2, 0.22, 0.26)
#: Scene lights, fixed in world coordinates: (position (mm), intensity).
LIGHTS: tuple[tuple[tuple[float, float, float], float], ...] = (
    ((-300.0, 350.0, 600.0), 0.6),  # key, upper left
    ((350.0, -50.0, 500.0), 0.3),  # fill, right
    ((0.0, -3.5, 500.0), 0.2),  # frontal
)


@numba.njit(cache=True, nogil=True)
def _accumulate_normals(points, triangles, out):  # pragma: no cover - compiled
    out[:] = 0.0
    for t in range(triangles.shape[0]):
        i, j, k = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        ax, ay, az = (
            points[j, 0] - points[i, 0],
            points[j, 1] - points[i, 1],
            points[j, 2] - points[i, 2],
        )
        bx, by, bz = (
            points[k, 0] - points[i, 0],
            points[k, 1] - points[i, 1],
            points[k, 2] - points[i, 2],
        )
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        for v in (i, j, k):
            out[v, 0] += nx
            out[v, 1] += ny
            out[v, 2] += nz
    for v in range(out.shape[0]):
        norm = np.sqrt(out[v, 0] ** 2 + out[v, 1] ** 2 + out[v, 2] ** 2)
        if norm > 1e-12:
            out[v, 0] /= norm
            out[v, 1] /= norm
            out[v, 2] /= norm


def vertex_normals(points: np.ndarray, triangles: np.ndarray, out: np.ndarray | None = None):
    """Area-weighted unit vertex normals of a triangle mesh, ``(n, 3)``.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Vertex positions.
    triangles : ndarray, shape (m, 3) int64
        Vertex indices.
    out : ndarray, shape (n, 3), optional
        Where to write the normals (float32 or float64).
    """
    if out is None:
        out = np.empty(points.shape, dtype=np.float64)
    _accumulate_normals(np.ascontiguousarray(points), triangles, out)
    return out


class FaceRenderer:
    """Renders a :class:`~synth_face.face.Face` from the fixed frontal camera.

    Parameters
    ----------
    face : Face
        The face to draw.
    size : int
        Width and height of the images (pixels); 256 by default.
    lighting : {"lit", "albedo"}
        ``"lit"`` (default): fixed key, fill and frontal lights with Phong shading.
        ``"albedo"``: texture colour only (no shading), so that a surface point has the
        same colour in every pose: the true flow then explains the images up to resampling.

    Notes
    -----
    Rendering uses one VTK render window for the renderer's lifetime: call :meth:`close`
    (or use the renderer as a context manager) to release it.
    """

    def __init__(self, face: Face, size: int = 256, *, lighting: str = "lit") -> None:
        if not isinstance(face, Face):
            raise MiketalkError(f"FaceRenderer needs a synth_face.Face, got {type(face).__name__}")
        if lighting not in ("lit", "albedo"):
            raise MiketalkError(f"lighting must be 'lit' or 'albedo', got {lighting!r}")
        self.lighting = lighting
        self.face = face
        self.camera = Camera(size)
        self.size = int(size)
        self._mask: np.ndarray | None = None
        pl = pv.Plotter(off_screen=True, window_size=(self.size, self.size), lighting=None)
        pl.ren_win.SetMultiSamples(0)
        pl.ren_win.SetPointSmoothing(False)
        pl.ren_win.SetLineSmoothing(False)
        pl.ren_win.SetPolygonSmoothing(False)
        pl.renderer.SetUseFXAA(False)
        pl.set_background(BACKGROUND)
        self._plotter = pl
        self._meshes: list[tuple[pv.PolyData, slice, np.ndarray]] = []
        for part in face.parts:
            sl = face.vertex_slices[part.name]
            tris = part.triangles
            cells = np.hstack([np.full((tris.shape[0], 1), 3), tris]).ravel()
            mesh = pv.PolyData(part.rest.copy(), faces=cells)
            mesh.active_texture_coordinates = part.uv.astype(np.float32)
            mesh.point_data["Normals"] = vertex_normals(part.rest, tris).astype(np.float32)
            mesh.point_data.active_normals_name = "Normals"
            tex = pv.Texture(np.ascontiguousarray(part.texture))
            tex.interpolate = True
            tex.mipmap = True
            tex.repeat = False
            tex.edge_clamp = True
            # Anisotropic filtering costs llvmpipe more than the rest of the frame together.
            tex.SetMaximumAnisotropicFiltering(1.0)
            m = part.material if lighting == "lit" else Material(ambient=1.0, diffuse=0.0)
            actor = pl.add_mesh(
                mesh,
                texture=tex,
                color="white",
                ambient=m.ambient,
                diffuse=m.diffuse,
                specular=m.specular,
                specular_power=m.specular_power,
                smooth_shading=False,
                reset_camera=False,
            )
            actor.prop.interpolation = "phong"
            self._meshes.append((actor.mapper.dataset, sl, tris))
        for pos, intensity in LIGHTS:
            light = pv.Light(
                position=pos,
                focal_point=self.camera.center,
                intensity=intensity,
                light_type="scene light",
            )
            pl.add_light(light)
        cam = pl.camera
        cam.position = tuple(self.camera.position)
        cam.focal_point = self.camera.center
        cam.up = (0.0, 1.0, 0.0)
        cam.view_angle = self.camera.view_angle
        cam.clipping_range = (self.camera.distance - 250.0, self.camera.distance + 250.0)
        self._pixels = vtkUnsignedCharArray()

    # -- context manager -------------------------------------------------------------
    def __enter__(self) -> FaceRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the render window (the renderer cannot render afterwards)."""
        if self._plotter is not None:
            self._plotter.close()
            self._plotter = None

    # -- rendering -------------------------------------------------------------------
    def vertices(self, params: np.ndarray, rigid: np.ndarray | None = None) -> np.ndarray:
        """World vertex positions at ``params``, optionally moved by a 4x4 rigid transform."""
        return apply_transform(self.face.vertices(params), rigid)

    def render(self, params: np.ndarray, *, rigid: np.ndarray | None = None) -> np.ndarray:
        """Render the face at ``params``.

        Parameters
        ----------
        params : array_like, shape (P,)
            Mouth parameters (``face.param_names`` order).
        rigid : ndarray, shape (4, 4), optional
            A rigid transform of the whole face (for testing the true flow).

        Returns
        -------
        ndarray, shape (size, size, 3) uint8
            The image, top row first.
        """
        if self._plotter is None:
            raise MiketalkError("this FaceRenderer was closed; create a new one")
        verts = self.vertices(params, rigid)
        for mesh, sl, tris in self._meshes:
            pts = verts[sl]
            mesh.points[:] = pts
            mesh.GetPoints().Modified()
            normals = mesh.point_data["Normals"]
            vertex_normals(pts, tris, out=normals)
            normals.Modified()
            mesh.Modified()
        win = self._plotter.ren_win
        win.Render()
        n = self.size
        win.GetPixelData(0, 0, n - 1, n - 1, 0, self._pixels, 0)
        img = vtk_to_numpy(self._pixels).reshape(n, n, 3)
        return np.ascontiguousarray(img[::-1])

    # -- ground truth ----------------------------------------------------------------
    def true_flow(
        self,
        p_a: np.ndarray,
        p_b: np.ndarray,
        *,
        rigid_a: np.ndarray | None = None,
        rigid_b: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The true flow from the image at ``p_a`` to the image at ``p_b``.

        Parameters
        ----------
        p_a, p_b : array_like, shape (P,)
            Mouth parameters of images A and B.
        rigid_a, rigid_b : ndarray, shape (4, 4), optional
            Rigid transforms of the whole face in A and B (for testing).

        Returns
        -------
        flow : ndarray, shape (size, size, 2) float32
            For each pixel of A, the displacement (dx, dy) to where the same surface point
            appears in B (zero where ``valid`` is False).
        valid : ndarray, shape (size, size) bool
            False on the background, where the point leaves the image, and where it is
            hidden in B.
        """
        return true_flow(
            self.camera,
            self.face.triangles,
            self.vertices(p_a, rigid_a),
            self.vertices(p_b, rigid_b),
        )

    def mouth_mask(self) -> np.ndarray:
        """The mouth region for metrics, ``(size, size)`` bool, the same for all parameters.

        The convex hull of the lips (vermilion and inner lip) over all corpus targets,
        dilated by 3% of the image size.
        """
        if self._mask is None:
            self._mask = mouth_mask(self.face, self.camera)
        return self._mask.copy()
