"""Eigenlips: principal components of a person's grey mouth boxes (Bregler & Konig 1994).

A mouth shape described without a learned landmark model: each frame's mouth box,
normalized to zero mean and unit variance, projected on the first principal
components of the training frames' boxes.
"""

from __future__ import annotations

import numpy as np

from miketalk.errors import MiketalkError

#: How many eigenlip coefficients are kept by default.
N_EIGENLIPS = 3


class Eigenlips:
    """Principal components of mouth regions ("eigenlips", Bregler & Konig 1994).

    Fitted on the grey mouth boxes of the training frames; :meth:`project`
    gives each frame's coefficients on the first ``n`` components.

    Parameters
    ----------
    mouths : (N, h, w) array
        Grey mouth boxes of the training frames.
    n : int
        Components kept.
    """

    def __init__(self, mouths: np.ndarray, *, n: int = N_EIGENLIPS) -> None:
        data = normalized(mouths)
        if len(data) <= n:
            raise MiketalkError(f"eigenlips need more than {n} training frames, got {len(data)}")
        self.mean = data.mean(axis=0)
        data -= self.mean  # in place: a long corpus's frames are held once
        # the right singular vectors of the centred data are the principal axes
        _, s, vt = np.linalg.svd(data, full_matrices=False)
        self.components = vt[:n]
        self.variance = (s[:n] ** 2) / (len(data) - 1)
        self.explained = self.variance / float((s**2).sum() / (len(data) - 1))
        # sign convention: each axis points the way the mouth darkens (opens)
        darker = -np.sign(self.components.sum(axis=1))
        self.components *= np.where(darker == 0, 1.0, darker)[:, None]

    @classmethod
    def restore(cls, *, mean, components, variance, explained) -> Eigenlips:
        """Eigenlips fitted before (:mod:`miketalk.corpus.eigenlips`), from their arrays."""
        self = cls.__new__(cls)
        self.mean, self.components = np.asarray(mean), np.asarray(components)
        self.variance, self.explained = np.asarray(variance), np.asarray(explained)
        return self

    def project(self, mouths: np.ndarray) -> np.ndarray:
        """Coefficients ``(N, n)`` of grey mouth boxes ``(N, h, w)``."""
        flat = normalized(mouths)
        flat -= self.mean
        return flat @ self.components.T


def normalized(mouths: np.ndarray) -> np.ndarray:
    """Each mouth box ``(N, h, w)`` as a row (float64), normalized to zero mean and unit variance.

    The normalization removes what differs between recordings rather than
    between mouth shapes (exposure, white balance, light on the face), which
    otherwise is the first principal component of clips recorded on
    different days (Bregler & Konig normalize the same way).
    """
    flat = np.asarray(mouths).reshape(len(mouths), -1).astype(np.float64)
    flat -= flat.mean(axis=1, keepdims=True)
    spread = flat.std(axis=1, keepdims=True)
    flat /= np.where(spread > 0, spread, 1.0)  # in place: a long corpus's frames held once
    return flat
