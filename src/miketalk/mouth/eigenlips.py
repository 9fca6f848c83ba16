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
        from scipy.linalg import eigh

        count = len(mouths)
        if count <= n:
            raise MiketalkError(f"eigenlips need more than {n} training frames, got {count}")
        box = tuple(np.shape(mouths)[1:])
        self.mean = sum(normalized(block).sum(axis=0) for block in _blocks(mouths)) / count
        pixels = len(self.mean)
        top = min(n, pixels, count - 1)
        if count < pixels:
            # few frames: the principal axes from the (frames x frames) Gram matrix
            centred = normalized(mouths)
            centred -= self.mean
            gram = centred @ centred.T
            values, vectors = eigh(gram, subset_by_index=[count - top, count - 1])
            total = float(np.trace(gram))
            axes = (centred.T @ vectors).T / np.sqrt(np.clip(values, 1e-300, None))[:, None]
        else:
            # many frames: the (pixels x pixels) scatter matrix, a block of frames at a time,
            # so that a long corpus's mouths are held once, as given (an SVD of the whole
            # float64 matrix would hold it three times over)
            scatter = np.zeros((pixels, pixels))
            for block in _blocks(mouths):
                centred = normalized(block)
                centred -= self.mean
                scatter += centred.T @ centred
            values, vectors = eigh(scatter, subset_by_index=[pixels - top, pixels - 1])
            total = float(np.trace(scatter))
            axes = vectors.T
        order = np.argsort(values)[::-1]
        self.components = np.ascontiguousarray(axes[order])
        self.variance = np.clip(values[order], 0.0, None) / (count - 1)
        self.explained = self.variance / (total / (count - 1))
        # sign convention: each axis points the way the box's centre darkens against its
        # edges (the mouth opens); every normalized box sums to zero, so the sum of an
        # axis's pixels cannot tell
        darker = np.sign(self.components @ centre_darkening(box if len(box) == 2 else (1, pixels)))
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
        # a block at a time: each block's float64 copy is let go before the next is made
        out = [(normalized(block) - self.mean) @ self.components.T for block in _blocks(mouths)]
        return np.concatenate(out) if out else np.empty((0, len(self.components)))


def centre_darkening(box: tuple[int, int]) -> np.ndarray:
    """``(h * w,)``: the change of a box ``(h, w)`` whose centre darkens against its edges
    (a Gaussian bump at the centre, negated, less its mean); an axis that points this way
    has a positive dot product with it."""
    h, w = box
    y, x = np.linspace(-1.0, 1.0, h)[:, None], np.linspace(-1.0, 1.0, w)[None, :]
    bump = np.exp(-(x**2 + y**2) / (2 * 0.35**2))
    return -(bump - bump.mean()).ravel()


#: Mouth boxes normalized at a time (the fit and the projection hold this many as float64).
BLOCK = 512


def _blocks(mouths: np.ndarray):
    """``mouths`` in blocks of :data:`BLOCK` boxes (views, not copies)."""
    return (mouths[start : start + BLOCK] for start in range(0, len(mouths), BLOCK))


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
