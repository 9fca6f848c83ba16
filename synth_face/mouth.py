"""Inside the mouth: the two rows of teeth, the tongue, and the dark cavity behind them.

Depths are relative to the middle of the lips' contact line (z = 0 there, see ``skin``).
"""

from __future__ import annotations

import numpy as np

from synth_face.dental import ARCH_TEX_HALF_MM, LOWER_WIDTHS, UPPER_WIDTHS, tooth_bump, tooth_phase
from synth_face.part import Material, Part, grid_triangles
from synth_face.textures import cavity_texture, teeth_texture, tongue_texture

#: Tongue ellipsoid: centre and semi-axes (mm); its tip is the front (+z) pole.
TONGUE_CENTER = (0.0, -7.5, -28.0)
TONGUE_RADII = (18.0, 6.5, 16.5)

_N_ARCH = 181
_N_LABIAL = 16
_TEETH_MATERIAL = Material(ambient=0.3, diffuse=0.7, specular=0.2, specular_power=30.0)


def _smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    s = np.clip((t - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _edge_height(s: np.ndarray, widths: tuple[float, ...], upper: bool) -> np.ndarray:
    """Incisal edge height (mm) along the arch: incisors low, canine pointed, embrasures."""
    idx, t = tooth_phase(s, widths)
    bump = tooth_bump(s, widths)
    if upper:
        base = np.array([-1.3, -0.8, -1.0, -0.3, 0.0, 0.3])[idx]
        cusp = np.where(idx == 2, -0.7 * (1.0 - np.abs(2.0 * t - 1.0)), 0.0)
        return base + cusp + 0.35 * (1.0 - bump)
    base = np.array([0.2, 0.3, 0.5, 0.0, -0.3, -0.6])[idx]
    cusp = np.where(idx == 2, 0.5 * (1.0 - np.abs(2.0 * t - 1.0)), 0.0)
    return base + cusp - 0.3 * (1.0 - bump)


def _build_arch(upper: bool) -> Part:
    """A row of teeth as one closed-profile band swept along a parabolic arch."""
    widths = UPPER_WIDTHS if upper else LOWER_WIDTHS
    z_front, curv, x_half = (-6.8, 0.028, 25.0) if upper else (-8.6, 0.031, 22.0)
    y_root = 12.0 if upper else -11.0
    sign = 1.0 if upper else -1.0  # direction from the edge to the gum

    # Sample the arch uniformly in arc length s.
    xf = np.linspace(-x_half, x_half, 4001)
    slope = -2.0 * curv * xf
    seg = np.hypot(np.diff(xf), np.diff(curv * xf**2))
    sf = np.concatenate([[0.0], np.cumsum(seg)])
    sf -= np.interp(0.0, xf, sf)
    s = np.linspace(sf[0], sf[-1], _N_ARCH)
    x_arch = np.interp(s, sf, xf)
    z_arch = z_front - curv * x_arch**2
    slope = -2.0 * curv * x_arch
    nrm = np.stack([-slope, np.ones_like(slope)], axis=-1)  # outward (labial) in the xz plane
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)

    bump = tooth_bump(s, widths)
    y_edge = _edge_height(s, widths, upper)
    # Cross-section, gum (labial) -> incisal edge -> gum (lingual): offsets n (mm, outward)
    # and heights above the edge (mm, towards the gum).
    h = np.linspace(1.0, 0.0, _N_LABIAL)[:, None]
    span = np.abs(y_root - y_edge)[None, :]
    n_lab = (
        0.55 * np.sin(np.pi * h**0.7) * (0.4 + 0.6 * bump)
        - 0.55 * (1.0 - bump)
        + 0.6 * _smoothstep(0.75, 1.0, h)
    )
    d_lab = h * span
    n_ling = np.array([-1.0, -1.8, -3.5, -5.5, -6.5])[:, None] + 0.0 * bump
    d_ling = np.array([0.15, 0.6, 3.0, 6.0, 0.0])[:, None] + 0.0 * span
    d_ling[-1] = span[0]
    n_all = np.concatenate([n_lab, n_ling])
    d_all = np.concatenate([d_lab, d_ling])
    v_all = np.clip(d_all / span, 0.0, 1.0)

    px = x_arch[None, :] + n_all * nrm[None, :, 0]
    pz = z_arch[None, :] + n_all * nrm[None, :, 1]
    py = y_edge[None, :] + sign * d_all
    rest = np.stack([px, py, pz], axis=-1).reshape(-1, 3)
    rows = n_all.shape[0]
    uv = np.stack(
        [
            np.broadcast_to((s + ARCH_TEX_HALF_MM) / (2 * ARCH_TEX_HALF_MM), (rows, _N_ARCH)),
            v_all,
        ],
        axis=-1,
    ).reshape(-1, 2)
    return Part(
        name="upper_teeth" if upper else "lower_teeth",
        rest=rest,
        triangles=grid_triangles(rows, _N_ARCH, wrap=False),
        uv=uv,
        texture=teeth_texture(widths, upper),
        material=_TEETH_MATERIAL,
        attrs={},
    )


def build_upper_teeth() -> Part:
    """Upper teeth, fixed to the skull."""
    return _build_arch(upper=True)


def build_lower_teeth() -> Part:
    """Lower teeth, carried by the jaw."""
    return _build_arch(upper=False)


def build_tongue() -> Part:
    """The tongue: a flattened ellipsoid narrowing to its tip, with a median groove.

    Attribute ``zeta``: position along the tongue, -1 at the root to 1 at the tip.
    """
    n_theta, n_phi = 48, 72
    theta = np.linspace(0.03, np.pi - 0.03, n_theta)[:, None]  # from the tip backwards
    phi = 2.0 * np.pi * np.arange(n_phi)[None, :] / n_phi
    rx, ry, rz = TONGUE_RADII
    taper = 1.0 - 0.35 * np.maximum(np.cos(theta), 0.0) ** 2
    lx = rx * np.sin(theta) * np.cos(phi) * taper
    ly = ry * np.sin(theta) * np.sin(phi)
    ly = np.where(ly < 0.0, 0.6 * ly, ly)
    ly -= 0.9 * np.exp(-((lx / 2.5) ** 2)) * (np.sin(phi) > 0) * np.sin(theta)
    lz = rz * np.cos(theta) + 0.0 * phi
    cx, cy, cz = TONGUE_CENTER
    rest = np.stack([lx + cx, ly + cy, lz + cz], axis=-1).reshape(-1, 3)
    uv = np.stack([(lx + 20.0) / 40.0, (lz + 20.0) / 40.0], axis=-1).reshape(-1, 2)
    return Part(
        name="tongue",
        rest=rest,
        triangles=grid_triangles(n_theta, n_phi, wrap=True),
        uv=uv,
        texture=tongue_texture(),
        material=Material(ambient=0.3, diffuse=0.7, specular=0.12, specular_power=20.0),
        attrs={"zeta": (lz / rz).ravel()},
    )


def build_cavity() -> Part:
    """A dark concave wall behind the teeth: whatever the open mouth shows beyond them."""
    xs = np.linspace(-38.0, 38.0, 39)
    ys = np.linspace(-30.0, 22.0, 27)
    gx, gy = np.meshgrid(xs, ys[::-1])
    gz = -40.0 + 0.002 * (gx**2 + 1.2 * (gy + 5.0) ** 2)
    rest = np.stack([gx, gy, gz], axis=-1).reshape(-1, 3)
    uv = np.stack([(gx + 50.0) / 100.0, (gy + 50.0) / 100.0], axis=-1).reshape(-1, 2)
    return Part(
        name="cavity",
        rest=rest,
        triangles=grid_triangles(ys.size, xs.size, wrap=False),
        uv=uv,
        texture=cavity_texture(),
        material=Material(ambient=0.3, diffuse=0.6, specular=0.0),
        attrs={},
    )
