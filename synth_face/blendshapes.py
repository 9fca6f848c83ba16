"""The linear deformation model: one displacement field per mouth parameter.

``vertex = rest + sum_i p_i * delta_i``. Every field is a fixed per-vertex displacement (mm),
so the model is exactly linear in the parameters: rendering ``lerp(p_A, p_B, a)`` gives the
ideal in-between of A and B. Rotations (the jaw) enter linearised, as their first-order
displacement ``phi * (axis x (X - hinge))``.

Skin fields are written over the elliptic coordinates of :mod:`synth_face.skin`: ``q = sin(nu)``
is +1 at the middle of the upper lip, -1 at the middle of the lower lip and 0 at the corners,
``mu`` grows away from the mouth (0 on the inner lip).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth_face.part import Part
from synth_face.skin import C_MM


@dataclass(frozen=True)
class Param:
    """One mouth parameter: its name, range and meaning."""

    name: str
    low: float
    high: float
    doc: str


PARAMS: tuple[Param, ...] = (
    Param("jaw_open", 0.0, 1.0, "jaw rotation about the hinge; lower lip ~11 mm down at 1"),
    Param("lip_part", 0.0, 1.0, "lips part without the jaw: an elliptic slit 5 mm tall at 1"),
    Param("lip_spread", 0.0, 1.0, "corners pulled out and back (mouth ~22% wider), lips thin"),
    Param("lip_round", 0.0, 1.0, "corners drawn in (slit 1/3 as wide), lips protruded ~6.5 mm"),
    Param("lip_press", 0.0, 1.0, "lips pressed: flattened and thinned (b, p, m)"),
    Param("upper_lip_raise", 0.0, 1.0, "upper lip lifted ~4.5 mm, showing the upper teeth"),
    Param("lower_lip_tuck", 0.0, 1.0, "lower lip up and back, under the upper teeth (f, v)"),
    Param("tongue_tip", 0.0, 1.0, "tongue tip raised to the teeth / alveolar ridge (t, d, n, l)"),
    Param("tongue_out", 0.0, 1.0, "tongue tip pushed forward between the teeth (th, dh)"),
)

PARAM_NAMES: tuple[str, ...] = tuple(p.name for p in PARAMS)

#: Jaw hinge (mm, world) and opening angle at jaw_open = 1 (radians).
JAW_HINGE = np.array([0.0, 32.0, -85.0])
JAW_ANGLE = 0.13


def _smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    s = np.clip((t - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _bell(mu: np.ndarray, width: float) -> np.ndarray:
    return np.exp(-((mu / width) ** 2))


def _positive(q: np.ndarray, eps: float = 0.15) -> np.ndarray:
    """A smooth ``max(q, 0)`` scaled to 1 at q = 1 (about 0.07 at q = 0, 0.01 at q = -1).

    Smooth in q, so fields built on it have no crease along the line through the corners.
    """
    return (q + np.sqrt(q * q + eps * eps)) / (1.0 + np.sqrt(1.0 + eps * eps))


def jaw_displacement(points: np.ndarray) -> np.ndarray:
    """Linearised jaw rotation (mm) at ``jaw_open = 1``: down and slightly back."""
    rel = points - JAW_HINGE
    out = np.zeros_like(points)
    out[:, 1] = -JAW_ANGLE * rel[:, 2]
    out[:, 2] = JAW_ANGLE * rel[:, 1]
    return out


def _skin_deltas(part: Part) -> np.ndarray:
    a = part.attrs
    mu, sigma, xc, yo, lip = a["mu"], a["sigma"], a["xc"], a["yo"], a["lip"]
    q = np.sin(a["nu"])
    xr = xc / C_MM
    n = mu.size
    d = {name: np.zeros((n, 3)) for name in PARAM_NAMES}

    # Jaw: the lower lip and chin turn with the mandible; the corners go half way, the
    # cheeks less, the upper lip and nose not at all. Sharper away from the slit.
    k = 1.0 + 3.0 * _smoothstep(0.1, 0.9, mu)
    w_jaw = 0.5 * (1.0 - np.clip(q * k, -1.0, 1.0))
    w_jaw *= np.exp(-(np.maximum(np.abs(xc) - 38.0, 0.0) ** 2) / (2 * 14.0**2))
    d["jaw_open"] = w_jaw[:, None] * jaw_displacement(part.rest)

    # Lip part: an elliptic opening (q is the ellipse's height profile along the slit).
    d["lip_part"][:, 1] = 2.5 * q * _bell(mu, 0.35)

    # Spread: corners out, back and a little up; the vermilion thins.
    d["lip_spread"][:, 0] = 5.5 * xr * _bell(mu, 0.7)
    d["lip_spread"][:, 1] = -0.22 * yo * _bell(mu, 0.35) + 0.8 * xr**2 * _bell(mu, 0.5)
    d["lip_spread"][:, 2] = -2.2 * xr**2 * _bell(mu, 0.6)

    # Round: corners drawn to the middle, lips pushed forward and everted.
    d["lip_round"][:, 0] = -(16.0 * _bell(mu, 0.35) + 3.0 * _bell(mu, 0.8)) * xr
    d["lip_round"][:, 1] = 1.2 * q * (1.0 - _bell(mu, 0.12)) * _bell(mu, 0.45)
    d["lip_round"][:, 2] = 6.5 * _bell(mu, 0.5) * (1.0 - 0.3 * np.minimum(xr**2, 1.0))

    # Press: flatten the lip bulge, thin the vermilion.
    d["lip_press"][:, 1] = -0.2 * yo * _bell(mu, 0.3)
    d["lip_press"][:, 2] = -0.4 * lip

    # Upper lip raise: lift (elliptic profile along the slit) with a slight eversion.
    qu = _positive(q)
    d["upper_lip_raise"][:, 1] = 4.5 * qu**0.8 * _bell(mu, 0.45)
    d["upper_lip_raise"][:, 2] = 1.0 * qu * _bell(mu, 0.3)

    # Lower lip tuck: up and back, the inner lip rolling further back.
    ql = _positive(-q) ** 0.8
    d["lower_lip_tuck"][:, 1] = ql * (1.5 * _bell(mu, 0.35) - 0.35 * yo * _bell(mu, 0.5))
    d["lower_lip_tuck"][:, 2] = -(5.5 * _bell(mu, 0.3) + 1.5 * sigma) * ql
    return np.stack([d[name] for name in PARAM_NAMES])


def _tongue_deltas(part: Part) -> np.ndarray:
    zeta = part.attrs["zeta"]
    out = np.zeros((len(PARAM_NAMES), zeta.size, 3))
    out[PARAM_NAMES.index("jaw_open")] = jaw_displacement(part.rest)
    w_tip = _smoothstep(-0.2, 1.0, zeta) ** 2
    i = PARAM_NAMES.index("tongue_tip")
    out[i, :, 1], out[i, :, 2] = 10.0 * w_tip, 2.5 * w_tip
    w_out = _smoothstep(0.0, 1.0, zeta) ** 2
    i = PARAM_NAMES.index("tongue_out")
    out[i, :, 1], out[i, :, 2] = 8.5 * w_out, 9.5 * w_out
    return out


def part_deltas(part: Part) -> np.ndarray:
    """Displacement fields of a part, shape ``(P, n, 3)`` in :data:`PARAM_NAMES` order."""
    if part.name == "skin":
        return _skin_deltas(part)
    if part.name == "tongue":
        return _tongue_deltas(part)
    out = np.zeros((len(PARAM_NAMES), part.rest.shape[0], 3))
    if part.name == "lower_teeth":
        out[PARAM_NAMES.index("jaw_open")] = jaw_displacement(part.rest)
    return out
