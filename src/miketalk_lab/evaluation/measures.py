"""Image and sync measures: PSNR, SSIM, sharpness, correlation, motion lag."""

from __future__ import annotations

import cv2
import numpy as np

from miketalk.errors import MiketalkError


def _crop(mask: np.ndarray | None) -> tuple[slice, slice]:
    if mask is None:
        return slice(None), slice(None)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        raise MiketalkError("the region mask is empty")
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def psnr(image: np.ndarray, reference: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Peak signal-to-noise ratio in dB of uint8 images, over ``mask`` (all pixels if None).

    Identical images give ``inf``.
    """
    if image.shape != reference.shape:
        raise MiketalkError(f"image shapes differ: {image.shape} vs {reference.shape}")
    diff = image.astype(np.float64) - reference.astype(np.float64)
    if mask is not None:
        diff = diff[mask]
    mse = float(np.mean(diff * diff))
    return float("inf") if mse == 0 else 10.0 * np.log10(255.0**2 / mse)


def ssim(image: np.ndarray, reference: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Structural similarity of uint8 images over the bounding box of ``mask``.

    The same number as ``skimage.metrics.structural_similarity(a, b,
    data_range=255)`` (7x7 uniform window, sample covariances, K1 = 0.01,
    K2 = 0.03, the window's half-width cropped from the borders, channels
    averaged), computed with OpenCV's box filter about ten times faster.
    """
    if image.shape != reference.shape:
        raise MiketalkError(f"image shapes differ: {image.shape} vs {reference.shape}")
    rows, cols = _crop(mask)
    a = image[rows, cols].astype(np.float64)
    b = reference[rows, cols].astype(np.float64)
    win, pad = _SSIM_WIN, (_SSIM_WIN - 1) // 2
    if min(a.shape[:2]) < win:
        raise MiketalkError(f"SSIM needs a region of at least {win}x{win} pixels")

    def mean(x: np.ndarray) -> np.ndarray:
        return cv2.boxFilter(x, cv2.CV_64F, (win, win), borderType=cv2.BORDER_REFLECT)

    ux, uy = mean(a), mean(b)
    cov = win * win / (win * win - 1.0)  # sample covariance
    vx = cov * (mean(a * a) - ux * ux)
    vy = cov * (mean(b * b) - uy * uy)
    vxy = cov * (mean(a * b) - ux * uy)
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    s = ((2 * ux * uy + c1) * (2 * vxy + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2))
    return float(s[pad:-pad, pad:-pad].mean())


_SSIM_WIN = 7


def sharpness(image: np.ndarray, mask: np.ndarray | None = None) -> float:
    """The fine detail of a uint8 image over the bounding box of ``mask``: the mean square
    of its grey level's Laplacian (3x3), in grey levels squared.

    PSNR favours a soft picture (an average of the likely images is nearer every one of
    them than any sharp one): the ratio of a synthesized mouth's sharpness to the real
    one's tells a blurred mouth (under 1) from one as crisp as the video (about 1).
    """
    rows, cols = _crop(mask)
    crop = np.asarray(image)[rows, cols].astype(np.float32)
    grey = cv2.cvtColor(crop, cv2.COLOR_RGB2GRAY) if crop.ndim == 3 else crop
    laplacian = cv2.Laplacian(grey, cv2.CV_32F, ksize=1, borderType=cv2.BORDER_REFLECT)
    return float(np.mean(laplacian.astype(np.float64) ** 2))


def box_mask(shape: tuple[int, ...], box: tuple[int, int, int, int]) -> np.ndarray:
    """``(H, W)`` bool mask of ``box`` ``(x, y, w, h)`` in images of ``shape`` ``(H, W, ...)``."""
    x, y, w, h = box
    mask = np.zeros(shape[:2], bool)
    mask[y : y + h, x : x + w] = True
    return mask


def sharpness_ratio(synthesized, real, mask: np.ndarray | None = None) -> float:
    """Mean :func:`sharpness` of the ``synthesized`` frames over that of the ``real`` ones."""
    return ratio_of_means(
        [sharpness(f, mask) for f in synthesized], [sharpness(f, mask) for f in real]
    )


def ratio_of_means(values, reference) -> float:
    """``mean(values) / mean(reference)``, the divisor kept off zero (a flat reference)."""
    return float(np.mean(values)) / max(float(np.mean(reference)), 1e-12)


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation; 0 when either signal is constant (a still face correlates with none)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    # a constant signal projected through floating point wobbles by ~1e-15: still constant
    if a.std() <= 1e-9 * (1 + np.abs(a).max()) or b.std() <= 1e-9 * (1 + np.abs(b).max()):
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])


def lag_frames(signal: np.ndarray, reference: np.ndarray, *, max_lag: int = 10) -> int:
    """The shift in frames that best aligns ``signal`` to ``reference``.

    Positive when ``signal`` lags (happens later than) ``reference``; found by
    normalized cross-correlation over ``-max_lag .. max_lag``.
    """
    n = min(len(signal), len(reference))
    a = signal[:n] - np.mean(signal[:n])
    b = reference[:n] - np.mean(reference[:n])
    best, best_score = 0, -np.inf
    for lag in range(-max_lag, max_lag + 1):
        x = a[lag:] if lag >= 0 else a[: n + lag]
        y = b[: n - lag] if lag >= 0 else b[-lag:]
        denom = np.sqrt(np.dot(x, x) * np.dot(y, y))
        score = np.dot(x, y) / denom if denom > 0 else -np.inf
        if score > best_score + 1e-12 or (
            abs(score - best_score) <= 1e-12 and abs(lag) < abs(best)
        ):
            best, best_score = lag, score
    return best
