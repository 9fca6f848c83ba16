"""The fixed frontal camera: one pinhole model shared by the renderer and the true flow.

World coordinates are millimetres: x to the face's left (image right), y up, z out of the
face towards the camera; the origin is the mouth centre (stomion) at rest. Pixel coordinates
follow the package convention: ``(col, row)`` with the origin at the centre of the top-left
pixel. VTK's display coordinates put pixel ``i`` over ``[i, i + 1)`` from the bottom-left, so a
point at normalized device coordinates ``(nx, ny)`` lands at
``col = (nx + 1) W / 2 - 0.5`` and ``row = (1 - ny) H / 2 - 0.5``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from miketalk.errors import MiketalkError

#: Where the camera looks (mm): slightly below the mouth so the chin is in frame.
FRAME_CENTER: tuple[float, float, float] = (0.0, -3.5, 0.0)
#: Height (and width) of the framed region in the plane z = 0 (mm).
FRAME_SIZE_MM = 125.0
#: Distance from the camera to the plane z = 0 (mm): a portrait lens, little perspective.
DISTANCE_MM = 500.0


@dataclass(frozen=True)
class Camera:
    """A square pinhole camera looking down -z at the face.

    Parameters
    ----------
    size : int
        Image width and height in pixels.
    center : tuple of float
        The focal point (mm).
    distance : float
        Camera distance from the focal point along +z (mm).
    frame_mm : float
        Height of the field of view at the focal point (mm).
    """

    size: int
    center: tuple[float, float, float] = FRAME_CENTER
    distance: float = DISTANCE_MM
    frame_mm: float = FRAME_SIZE_MM

    def __post_init__(self) -> None:
        if not isinstance(self.size, int | np.integer) or self.size < 16:
            raise MiketalkError(f"image size must be an integer >= 16 pixels, got {self.size!r}")

    @property
    def position(self) -> np.ndarray:
        """Camera centre in world coordinates (mm)."""
        cx, cy, cz = self.center
        return np.array([cx, cy, cz + self.distance])

    @property
    def view_angle(self) -> float:
        """Vertical field of view in degrees (VTK's ``ViewAngle``)."""
        return math.degrees(2.0 * math.atan(0.5 * self.frame_mm / self.distance))

    @property
    def focal_px(self) -> float:
        """Focal length in pixels."""
        return 0.5 * self.size / math.tan(math.radians(0.5 * self.view_angle))

    @property
    def principal_point(self) -> tuple[float, float]:
        """``(col, row)`` of the optical axis (between the two central pixels)."""
        c = 0.5 * self.size - 0.5
        return c, c

    def project(self, points: np.ndarray) -> np.ndarray:
        """Project world points to pixels.

        Parameters
        ----------
        points : ndarray, shape (..., 3)
            World coordinates (mm).

        Returns
        -------
        ndarray, shape (..., 3)
            ``(col, row, depth)``: pixel coordinates and the distance along the optical axis
            (mm, positive in front of the camera).
        """
        rel = np.asarray(points, dtype=np.float64) - self.position
        depth = -rel[..., 2]
        f = self.focal_px
        c0, r0 = self.principal_point
        out = np.empty(rel.shape, dtype=np.float64)
        out[..., 0] = c0 + f * rel[..., 0] / depth
        out[..., 1] = r0 - f * rel[..., 1] / depth
        out[..., 2] = depth
        return out

    def rotation_about_center(self, yaw_deg: float, pitch_deg: float) -> np.ndarray:
        """A rigid world transform that rotates the scene about the camera centre.

        Seen through the camera this moves every visible point by the same homography,
        whatever its depth, and changes no occlusion: the analytic case for testing flow.

        Parameters
        ----------
        yaw_deg, pitch_deg : float
            Rotation about the camera's vertical and horizontal axes (degrees).

        Returns
        -------
        ndarray, shape (4, 4)
            Homogeneous transform applied to world points (column vectors).
        """
        a, b = math.radians(yaw_deg), math.radians(pitch_deg)
        ry = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
        rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
        rot = ry @ rx
        c = self.position
        out = np.eye(4)
        out[:3, :3] = rot
        out[:3, 3] = c - rot @ c
        return out

    def homography_flow(self, transform: np.ndarray) -> np.ndarray:
        """The exact image motion of :meth:`rotation_about_center` (depth-free).

        Parameters
        ----------
        transform : ndarray, shape (4, 4)
            A transform returned by :meth:`rotation_about_center`.

        Returns
        -------
        ndarray, shape (size, size, 2) float64
            The displacement of every pixel centre (dx, dy).
        """
        n = self.size
        f = self.focal_px
        c0, r0 = self.principal_point
        rows, cols = np.mgrid[0:n, 0:n].astype(np.float64)
        # Camera axes are the world axes; a ray through (col, row) has direction d.
        d = np.stack([(cols - c0) / f, -(rows - r0) / f, -np.ones_like(cols)], axis=-1)
        d2 = d @ np.asarray(transform)[:3, :3].T
        col2 = c0 + f * d2[..., 0] / -d2[..., 2]
        row2 = r0 - f * d2[..., 1] / -d2[..., 2]
        return np.stack([col2 - cols, row2 - rows], axis=-1)


def apply_transform(points: np.ndarray, transform: np.ndarray | None) -> np.ndarray:
    """Apply a 4x4 rigid transform to ``(N, 3)`` points (identity if ``None``)."""
    if transform is None:
        return points
    t = np.asarray(transform, dtype=np.float64)
    if t.shape != (4, 4):
        raise MiketalkError(f"a rigid transform must be a 4x4 matrix, got shape {t.shape}")
    return points @ t[:3, :3].T + t[:3, 3]
