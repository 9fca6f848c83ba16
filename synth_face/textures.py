"""Procedural textures: skin with pores, stubble and freckles; lips; teeth; tongue; cavity.

Every texture is drawn in millimetres on its part's texture chart, from a fixed seed, so the
face looks the same in every process. Arrays are ``(h, w, 3)`` uint8 with the top row first
(texture coordinate v = 1 at the top).
"""

from __future__ import annotations

from functools import cache

import cv2
import numpy as np

from synth_face.dental import ARCH_TEX_HALF_MM, tooth_bump, tooth_phase

#: The skin chart covers rest (x, y) in [-SKIN_TEX_HALF_MM, SKIN_TEX_HALF_MM]^2.
SKIN_TEX_HALF_MM = 80.0
SKIN_TEX_PX = 2048
_SEED = 1999


def _smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    s = np.clip((t - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _noise(rng: np.random.Generator, shape: tuple[int, int], cell: tuple[float, float]):
    """Smooth unit-variance noise: Gaussian values on a grid of ``cell`` pixels, bicubic."""
    h, w = shape
    cy, cx = max(cell[0], 1.0), max(cell[1], 1.0)
    gh, gw = int(np.ceil(h / cy)) + 4, int(np.ceil(w / cx)) + 4
    grid = rng.standard_normal((gh, gw)).astype(np.float32)
    up = cv2.resize(grid, (round(gw * cx), round(gh * cy)), interpolation=cv2.INTER_CUBIC)
    oy, ox = round(2 * cy), round(2 * cx)
    out = up[oy : oy + h, ox : ox + w]
    return (out - out.mean()) / (out.std() + 1e-12)


def _spots(rng: np.random.Generator, shape: tuple[int, int], count: int, sigma: float):
    """``count`` Gaussian dots of radius ``sigma`` pixels and random strength, peak about 1."""
    h, w = shape
    idx = rng.integers(0, h * w, size=count)
    weight = rng.uniform(0.4, 1.0, size=count)
    img = np.bincount(idx, weights=weight, minlength=h * w).reshape(h, w).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), sigma) * (2.0 * np.pi * sigma * sigma)
    return np.clip(img, 0.0, 1.5)


def _to_uint8(col: np.ndarray) -> np.ndarray:
    out = np.clip(col * 255.0 + 0.5, 0, 255).astype(np.uint8)
    out.setflags(write=False)
    return out


def _chart(n: int, half: float) -> tuple[np.ndarray, np.ndarray]:
    """Millimetre coordinates (x right, y up) of the texel centres of an n x n chart."""
    c = (np.arange(n, dtype=np.float32) + 0.5) / n * 2 * half - half
    return np.meshgrid(c, c[::-1])


def lip_borders(x: np.ndarray, half_width: float) -> tuple[np.ndarray, np.ndarray]:
    """Heights (mm) of the upper lip's border (with Cupid's bow) and of the lower lip's."""
    r = np.clip(1.0 - (x / (half_width + 1.0)) ** 2, 0.0, None)
    ax = np.abs(x)
    upper = (
        8.3 * r**0.5 - 1.2 * np.exp(-((x / 2.4) ** 2)) + 0.5 * np.exp(-(((ax - 5.5) / 2.5) ** 2))
    )
    lower = -9.3 * r**0.55
    return upper * (r > 0), lower


@cache
def skin_texture(mouth_half_mm: float = 25.0) -> np.ndarray:
    """The face chart: skin (pores, stubble, freckles, moles), lips and nostrils."""
    rng = np.random.default_rng(_SEED)
    n = SKIN_TEX_PX
    ppm = n / (2 * SKIN_TEX_HALF_MM)  # texels per mm
    x, y = _chart(n, SKIN_TEX_HALF_MM)
    shape = (n, n)
    mm = lambda v: (v * ppm, v * ppm)  # noqa: E731 - cell size in texels

    lum = (
        1.0
        + 0.05 * _noise(rng, shape, mm(25.0))
        + 0.035 * _noise(rng, shape, mm(4.0))
        + 0.03 * _noise(rng, shape, mm(1.2))
        + 0.025 * _noise(rng, shape, mm(0.35))
    )
    red = 0.035 * _noise(rng, shape, mm(15.0)) + 0.012 * np.exp(
        -((x / 20.0) ** 2) - ((y + 30.0) / 15.0) ** 2
    )
    col = np.array([0.80, 0.57, 0.47], np.float32) * lum[..., None]
    col += red[..., None] * np.array([1.0, -0.3, -0.3], np.float32)

    area = (2 * SKIN_TEX_HALF_MM) ** 2
    pores = _spots(rng, shape, int(2.0 * area), 0.12 * ppm)
    col *= (1.0 - 0.22 * pores)[..., None]
    # Shaved stubble over the beard area (below the nose, around the mouth, chin).
    upper_b, lower_b = lip_borders(x, mouth_half_mm)
    d = np.where(upper_b - lower_b > 0.0, np.minimum(upper_b - y, y - lower_b), -10.0)
    lips = _smoothstep(-0.25, 0.35, d)
    beard = _smoothstep(30.0, 24.0, y) * _smoothstep(62.0, 45.0, np.abs(x)) * (1.0 - lips)
    beard *= 0.6 + 0.4 * _smoothstep(-0.5, 1.0, _noise(rng, shape, mm(8.0)))
    stubble = _spots(rng, shape, int(5.0 * area), 0.07 * ppm)
    col *= 1.0 - 0.3 * (stubble * beard)[..., None] * np.array([1.0, 0.95, 0.85], np.float32)
    col *= (1.0 - 0.06 * beard)[..., None]
    freckles = _spots(rng, shape, 700, 0.35 * ppm) + _spots(rng, shape, 250, 0.6 * ppm)
    freckles *= rng.uniform(0.3, 0.6)
    col *= 1.0 - np.clip(freckles, 0, 1)[..., None] * np.array([0.25, 0.35, 0.45], np.float32)
    moles = _spots(rng, shape, 8, 0.9 * ppm)
    col *= 1.0 - np.clip(moles, 0, 1)[..., None] * np.array([0.45, 0.55, 0.6], np.float32)

    # Lips: vermilion with vertical lip lines, a darker mouth line, a light border roll.
    lip_lum = (
        1.0
        + 0.08 * _noise(rng, shape, (2.5 * ppm, 0.3 * ppm))
        + 0.04 * _noise(rng, shape, mm(1.5))
        + 0.03 * _noise(rng, shape, mm(0.4))
    )
    lip_col = np.array([0.66, 0.31, 0.33], np.float32) * lip_lum[..., None]
    lip_col *= (1.0 - 0.3 * np.exp(-((y / 1.2) ** 2)))[..., None]
    specks = _spots(rng, shape, int(1.5 * area), 0.1 * ppm)
    lip_col *= (1.0 - 0.12 * specks)[..., None]
    roll = np.exp(-(((d + 0.5) / 0.4) ** 2)) * (np.abs(x) < mouth_half_mm)
    col *= (1.0 + 0.06 * roll)[..., None]
    col = col * (1.0 - lips[..., None]) + lip_col * lips[..., None]

    # Nostrils.
    nos = np.exp(-(((np.abs(x) - 6.5) / 3.0) ** 2) - ((y - 30.5) / 1.6) ** 2)
    col = col * (1.0 - 0.8 * nos[..., None]) + 0.8 * nos[..., None] * np.array(
        [0.25, 0.12, 0.1], np.float32
    )
    return _to_uint8(col)


@cache
def teeth_texture(widths: tuple[float, ...], upper: bool) -> np.ndarray:
    """Teeth chart: arc length across (``+-ARCH_TEX_HALF_MM``), edge (bottom) to gum (top)."""
    rng = np.random.default_rng(_SEED + (1 if upper else 2))
    h, w = 256, 1024
    s = (np.arange(w, dtype=np.float64) + 0.5) / w * 2 * ARCH_TEX_HALF_MM - ARCH_TEX_HALF_MM
    v = 1.0 - (np.arange(h, dtype=np.float64) + 0.5) / h
    S, V = np.meshgrid(s, v)
    idx, t = tooth_phase(S, widths)
    bump = tooth_bump(S, widths)
    shade = rng.uniform(0.9, 1.0, size=len(widths))[idx]
    ppm = w / (2 * ARCH_TEX_HALF_MM)
    enamel = np.array([0.91, 0.88, 0.80]) * shade[..., None]
    enamel = enamel * (1.0 - 0.3 * V[..., None]) + 0.3 * V[..., None] * np.array([0.85, 0.78, 0.6])
    enamel *= (1.0 + 0.03 * _noise(rng, (h, w), (0.6 * ppm, 0.6 * ppm)))[..., None]
    width_mm = np.asarray(widths)[idx]
    gap = np.exp(-((np.minimum(t, 1.0 - t) * width_mm / 0.25) ** 2))
    col = enamel * (1 - 0.8 * gap[..., None]) + 0.8 * gap[..., None] * np.array([0.35, 0.28, 0.25])
    edge = 0.4 * np.clip(1.0 - V / 0.07, 0.0, 1.0)
    col = col * (1 - edge[..., None]) + edge[..., None] * np.array([0.7, 0.72, 0.78])
    gum_line = 0.74 + 0.1 * bump
    gum = _smoothstep(-0.02, 0.02, V - gum_line)
    gum_col = (
        np.array([0.72, 0.36, 0.38])
        * (1.0 + 0.06 * _noise(rng, (h, w), (1.0 * ppm, 1.0 * ppm)))[..., None]
    )
    col = col * (1 - gum[..., None]) + gum_col * gum[..., None]
    col *= (0.5 + 0.5 * np.exp(-((S / 20.0) ** 2)))[..., None]  # farther teeth are in shadow
    return _to_uint8(col.astype(np.float32))


@cache
def tongue_texture() -> np.ndarray:
    """Tongue chart (top view, 40 mm square): pink, papillae, a median groove."""
    rng = np.random.default_rng(_SEED + 3)
    n = 512
    ppm = n / 40.0
    x, z = _chart(n, 20.0)
    lum = (
        1.0
        + 0.07 * _noise(rng, (n, n), (2.0 * ppm, 2.0 * ppm))
        + 0.05 * _noise(rng, (n, n), (0.6 * ppm, 0.6 * ppm))
    )
    pap = _spots(rng, (n, n), 6 * 1600, 0.09 * ppm) - _spots(rng, (n, n), 4 * 1600, 0.09 * ppm)
    lum = lum + 0.15 * pap - 0.2 * np.exp(-((x / 1.2) ** 2)) * (z < 12.0)
    col = np.array([0.73, 0.36, 0.39], np.float32) * lum[..., None]
    return _to_uint8(col)


@cache
def cavity_texture() -> np.ndarray:
    """The mouth's dark interior, with faint blotches."""
    rng = np.random.default_rng(_SEED + 4)
    n = 256
    ppm = n / 100.0
    lum = (
        1.0
        + 0.15 * _noise(rng, (n, n), (3.0 * ppm, 3.0 * ppm))
        + 0.1 * _noise(rng, (n, n), (1.0 * ppm, 1.0 * ppm))
    )
    col = np.array([0.17, 0.06, 0.07], np.float32) * lum[..., None]
    return _to_uint8(col)
