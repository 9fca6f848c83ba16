"""The skin and lips: one surface, meshed on confocal elliptic coordinates around the mouth.

A point of the outer surface has coordinates ``(mu, nu)`` with
``x = C cosh(mu) cos(nu)``, ``y = C sinh(mu) sin(nu)``: the ring ``mu = 0`` is the segment
between the mouth corners ``(+-C, 0)``, covered twice: ``0 < nu < pi`` is the upper lip's
edge, ``pi < nu < 2 pi`` the lower lip's. The two copies share rest positions but are distinct
vertices, so the mouth is a slit that opens when the lips move apart. Rings get denser towards
the slit (the mesh is densest around the mouth), and behind the slit the lips roll inwards as
``N_INNER`` extra rings (the inner lip, ``sigma`` from 0 at the contact to 1 inside).

Depth ``z(x, y)`` is a sum of smooth bumps: face curvature, the muzzle over the teeth, nose,
philtrum, nasolabial folds, cheeks, the groove under the lower lip, chin, the lips, and a
roll-off at the face outline that turns the surface away from the camera (a silhouette
against the background).
"""

from __future__ import annotations

import math

import numpy as np

from synth_face.part import Material, Part, grid_triangles
from synth_face.textures import SKIN_TEX_HALF_MM, skin_texture

#: Half the mouth width at rest (mm): the foci of the elliptic grid are the mouth corners.
C_MM = 25.0
#: Vertices around each ring (even, so the corners are vertices 0 and N_NU / 2).
N_NU = 256
#: Rings of the inner lip, behind the contact line.
N_INNER = 6
#: How far the inner lip reaches back (mm) and how far it curls away from the slit (mm).
INNER_DEPTH_MM = 5.5
INNER_RISE_MM = 3.0
#: Outermost ring and the ring spacing d(mu) = A + B mu.
MU_MAX = 2.0
_DMU_A, _DMU_B = 0.008, 0.02
#: Lip bulge (mm) of the upper and lower lip, and where its profile peaks in mu.
LIP_BULGE_UPPER, LIP_BULGE_LOWER = 5.0, 4.4
_LIP_PEAK, _LIP_WIDTH = 0.13, 0.14
#: Face outline: half-width above the jaw line (mm), chin depth below the mouth (mm).
OUTLINE_HALF_MM, CHIN_MM, JAW_TOP_MM = 66.0, 52.0, -5.0
_ROLL_MM = 10.0


def mu_rings() -> np.ndarray:
    """The ``mu`` of every outer ring, 0 (the slit) first, spacing growing geometrically."""
    k_max = math.ceil(math.log1p(MU_MAX * _DMU_B / _DMU_A) / math.log1p(_DMU_B))
    k = np.arange(k_max + 1, dtype=np.float64)
    return _DMU_A / _DMU_B * np.expm1(k * math.log1p(_DMU_B))


def _g(x: np.ndarray, y: np.ndarray, cx: float, cy: float, sx: float, sy: float) -> np.ndarray:
    return np.exp(-(((x - cx) / sx) ** 2) - ((y - cy) / sy) ** 2)


def _smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    s = np.clip((t - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def outline_inside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Approximate distance (mm) inside the face outline; negative outside.

    Straight cheeks (``|x| = OUTLINE_HALF_MM``) above the jaw line, a superellipse jaw
    down to the chin below it.
    """
    p = 2.3
    r = ((np.abs(x) / OUTLINE_HALF_MM) ** p + (np.maximum(JAW_TOP_MM - y, 0.0) / CHIN_MM) ** p) ** (
        1.0 / p
    )
    return OUTLINE_HALF_MM * (1.0 - r)


def _rolloff(u: np.ndarray) -> np.ndarray:
    """Depth offset that folds the surface away from the camera at the outline."""
    re = _ROLL_MM
    inside = np.clip(u, 0.0, re)
    z = -(re - np.sqrt(np.maximum(re * re - (re - inside) ** 2, 0.0)))
    return np.where(u >= 0.0, z, -re + 12.0 * u)


def lip_profile(mu: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Lip bulge (mm) over the elliptic coordinates; equal on both copies of the slit."""
    q = np.sin(nu)
    mean = 0.5 * (LIP_BULGE_UPPER + LIP_BULGE_LOWER)
    half = 0.5 * (LIP_BULGE_UPPER - LIP_BULGE_LOWER)
    amp = mean + half * np.sign(q) * np.tanh(mu / 0.06)
    prof = np.exp(-(((mu - _LIP_PEAK) / _LIP_WIDTH) ** 2))
    return amp * prof * corner_taper(q)


def corner_taper(q: np.ndarray, power: float = 0.35, eps: float = 0.2) -> np.ndarray:
    """A smooth ``|q| ** power``: 0 at the corners' line (q = 0), 1 mid-lip (|q| = 1).

    Smooth through q = 0, so the surface has no crease along the line through the corners.
    """
    e = eps**2
    return ((q * q + e) ** (power / 2) - e ** (power / 2)) / (
        (1 + e) ** (power / 2) - e ** (power / 2)
    )


def surface_depth(x: np.ndarray, y: np.ndarray, mu: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Rest depth z (mm) of the outer surface, before centring on the mouth."""
    ax = np.abs(x)
    z = -(x**2) / (2 * 85.0) - (y + 5.0) ** 2 / (2 * 300.0) + 0.05 * y
    z += 7.0 * _g(x, y, 0.0, -2.0, 30.0, 26.0)  # muzzle over the dental arch
    z += 19.0 * _g(x, y, 0.0, 43.0, 8.5, 10.0)  # nose tip
    z += 7.0 * _g(x, y, 0.0, 34.0, 14.0, 7.0)  # nose base
    z += 5.0 * _g(ax, y, 14.0, 33.0, 6.0, 6.0)  # alae
    window = _smoothstep(9.0, 13.0, y) * (1.0 - _smoothstep(24.0, 30.0, y))
    z += (0.9 * np.exp(-(((ax - 5.0) / 1.8) ** 2)) - 0.6 * np.exp(-((x / 2.5) ** 2))) * window
    # nasolabial folds: a crease along the segment (17, 30) -> (34, -6), mirrored
    p1, p2 = np.array([17.0, 30.0]), np.array([34.0, -6.0])
    seg = p2 - p1
    t = np.clip(((ax - p1[0]) * seg[0] + (y - p1[1]) * seg[1]) / (seg @ seg), 0.0, 1.0)
    d = np.hypot(ax - p1[0] - t * seg[0], y - p1[1] - t * seg[1])
    z += -1.3 * np.exp(-((d / 2.2) ** 2)) + 1.4 * np.exp(-(((d - 5.0) / 3.5) ** 2)) * (
        ax > p1[0] + t * seg[0]
    )
    z += 5.0 * _g(ax, y, 42.0, 18.0, 16.0, 18.0)  # cheeks
    z -= 2.4 * np.exp(-(((y + 17.0) / 4.5) ** 2)) * np.exp(-((x / 24.0) ** 2))  # under the lip
    z += 6.0 * _g(x, y, 0.0, -38.0, 17.0, 12.0)  # chin
    z += lip_profile(mu, nu)
    z += _rolloff(outline_inside(x, y))
    return z


def build_skin() -> Part:
    """The skin-and-lips part: rest mesh, texture coordinates and blendshape attributes.

    Attributes (``Part.attrs``) per vertex: ``mu`` (0 on the inner lip), ``nu``, ``sigma``
    (inner-lip depth, 0 on the outer surface), ``xc`` (rest x, or the contact's x on the inner
    lip), ``yo`` (rest y on the outer surface, 0 on the inner lip), ``lip`` (lip bulge, mm).
    """
    mu_outer = mu_rings()
    sig = np.linspace(1.0, 0.0, N_INNER + 1)[:-1]  # deepest inner ring first
    nu = 2.0 * np.pi * np.arange(N_NU) / N_NU
    n_rows = N_INNER + mu_outer.size

    mu = np.zeros((n_rows, N_NU))
    mu[N_INNER:] = mu_outer[:, None]
    sigma = np.zeros((n_rows, N_NU))
    sigma[:N_INNER] = sig[:, None]
    nug = np.broadcast_to(nu, (n_rows, N_NU))
    q = np.sin(nug)

    x = C_MM * np.cosh(mu) * np.cos(nug)
    y = C_MM * np.sinh(mu) * q
    z = surface_depth(x, y, mu, nug)
    # The inner lip: from the contact line, back into the mouth and away from the slit.
    xc = x.copy()
    inner = sigma > 0
    x = np.where(inner, xc * (1.0 - 0.06 * sigma), x)
    y = np.where(inner, INNER_RISE_MM * sigma**1.5 * q, y)
    z = np.where(inner, z - INNER_DEPTH_MM * sigma, z)
    # Centre depth on the mouth: z = 0 at the middle of the contact line.
    z0 = surface_depth(np.zeros(1), np.zeros(1), np.zeros(1), np.full(1, np.pi / 2))[0]
    z = z - z0

    rest = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    tris = grid_triangles(n_rows, N_NU, wrap=True)

    # Texture: planar in rest (x, y); the inner lip reuses the lip texture near the slit.
    u_mm = xc
    v_mm = np.where(inner, -1.6 * sigma * q, y)
    uv = np.stack(
        [
            (u_mm + SKIN_TEX_HALF_MM) / (2 * SKIN_TEX_HALF_MM),
            (v_mm + SKIN_TEX_HALF_MM) / (2 * SKIN_TEX_HALF_MM),
        ],
        axis=-1,
    ).reshape(-1, 2)

    attrs = {
        "mu": mu.ravel(),
        "nu": nug.ravel().copy(),
        "sigma": sigma.ravel(),
        "xc": xc.ravel(),
        "yo": np.where(inner, 0.0, y).ravel(),
        "lip": lip_profile(mu, nug).ravel(),
    }

    # Drop triangles far outside the outline or the frame, then unused vertices.
    xr, yr = xc.ravel(), (C_MM * np.sinh(mu) * q).ravel()
    keep_v = (outline_inside(xr, yr) > -6.0) & (np.abs(xr) < 85.0) & (yr < 80.0) & (yr > -85.0)
    keep_t = keep_v[tris].any(axis=1)
    tris = tris[keep_t]
    used = np.zeros(rest.shape[0], dtype=bool)
    used[tris.ravel()] = True
    remap = np.cumsum(used) - 1
    return Part(
        name="skin",
        rest=rest[used],
        triangles=remap[tris],
        uv=uv[used],
        texture=skin_texture(C_MM),
        material=Material(ambient=0.28, diffuse=0.75, specular=0.06, specular_power=12.0),
        attrs={k: v[used] for k, v in attrs.items()},
    )
