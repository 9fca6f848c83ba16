"""Ridge regression with an unpenalized intercept, at one strength or along several (the
trained face's window regression is fitted so, its strength chosen by cross-validation)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["ridge", "ridge_path"]


def ridge(x: np.ndarray, y: np.ndarray, strength: float) -> tuple[np.ndarray, np.ndarray]:
    """Ridge regression of ``y`` on ``x`` with an unpenalized intercept: (weights, intercept)."""
    return ridge_path(x, y, (strength,))[0]


def ridge_path(
    x: np.ndarray, y: np.ndarray, strengths: Sequence[float]
) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`ridge` at each of ``strengths``, the centred normal equations formed once.

    The same numbers as :func:`ridge` called at each strength (the Gram matrix plus the
    strength times the identity, solved): forming ``xc.T @ xc`` is most of a fit's work
    when the clips hold many more frames than features, and a cross-validation asks for
    six strengths of every fold.
    """
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc = x - mx
    gram, moment = xc.T @ xc, xc.T @ (y - my)
    eye = np.eye(x.shape[1])
    fits = []
    for strength in strengths:
        weights = np.linalg.solve(gram + strength * eye, moment)
        fits.append((weights, my - mx @ weights))
    return fits
