"""Tooth layout along a dental arch, shared by the teeth geometry and the teeth texture."""

from __future__ import annotations

import numpy as np

#: Crown widths along the arch from the midline (mm): incisors, canine, premolars, molar.
UPPER_WIDTHS: tuple[float, ...] = (8.5, 6.5, 7.5, 7.0, 7.0, 10.0)
LOWER_WIDTHS: tuple[float, ...] = (5.5, 6.0, 7.0, 7.0, 7.0, 11.0)
#: Half-range of arc length the teeth texture covers (mm).
ARCH_TEX_HALF_MM = 42.0


def tooth_phase(s: np.ndarray, widths: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Which tooth an arc-length position falls on, and where across it.

    Parameters
    ----------
    s : ndarray
        Signed arc length from the midline (mm).
    widths : tuple of float
        Crown widths from the midline outwards.

    Returns
    -------
    index : ndarray of int
        0 for the central incisor, 1 lateral, ... (clipped to the last tooth).
    t : ndarray of float
        Position across the crown, 0 and 1 at its edges.
    """
    edges = np.concatenate([[0.0], np.cumsum(widths)])
    a = np.abs(s)
    idx = np.clip(np.searchsorted(edges, a, side="right") - 1, 0, len(widths) - 1)
    t = np.clip((a - edges[idx]) / np.asarray(widths)[idx], 0.0, 1.0)
    return idx, t


def tooth_bump(s: np.ndarray, widths: tuple[float, ...]) -> np.ndarray:
    """1 at a crown's centre, 0 between two teeth."""
    _, t = tooth_phase(s, widths)
    return np.sqrt(np.sin(np.pi * t))
