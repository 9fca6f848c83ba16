"""Flow accuracy: endpoint error, two ground-truth problems, and the motorcycle table."""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import TYPE_CHECKING

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.flow.registry import ESTIMATORS, Estimator, get_estimator
from miketalk.flow.warp import backward_warp

if TYPE_CHECKING:
    import pandas as pd


def endpoint_error(
    flow: np.ndarray, true_flow: np.ndarray, mask: np.ndarray | None = None
) -> dict[str, float]:
    """Endpoint error ``|flow - true_flow|`` (Euclidean, pixels) summarised over ``mask``.

    Parameters
    ----------
    flow, true_flow : ndarray, shape (H, W, 2)
        Estimated and true flow. ``true_flow`` may hold NaN/inf outside ``mask``.
    mask : ndarray of bool, shape (H, W), optional
        Pixels to score (valid ground truth, the mouth region...). Default: the
        pixels where ``true_flow`` is finite.

    Returns
    -------
    dict
        ``mean_epe`` (pixels), ``pct_over_1px`` and ``pct_over_3px`` (percent
        of the scored pixels whose error exceeds 1 and 3 pixels), ``pixels``
        (how many were scored).

    Raises
    ------
    MiketalkError
        For mismatched shapes, an empty mask, or non-finite values inside it.

    Examples
    --------
    >>> import numpy as np
    >>> f = np.zeros((2, 2, 2), np.float32); g = f.copy(); g[0, 0] = (3.0, 4.0)
    >>> endpoint_error(f, g)["mean_epe"]
    1.25
    """
    return summarize_endpoint_error(endpoint_error_map(flow, true_flow), mask)


def endpoint_error_map(flow: np.ndarray, true_flow: np.ndarray) -> np.ndarray:
    """Per-pixel endpoint error ``|flow - true_flow|`` in pixels, float64, shape (H, W).

    Non-finite where either flow is; score it with :func:`summarize_endpoint_error`
    (several regions of one pair need only one map).

    Raises
    ------
    MiketalkError
        For mismatched shapes.
    """
    flow = np.asarray(flow)
    true_flow = np.asarray(true_flow)
    if flow.ndim != 3 or flow.shape[2] != 2:
        raise MiketalkError(f"flow must be (H, W, 2), got shape {flow.shape}")
    if true_flow.shape != flow.shape:
        raise MiketalkError(f"true_flow has shape {true_flow.shape}, flow has {flow.shape}")
    with np.errstate(invalid="ignore"):
        diff = flow.astype(np.float64) - true_flow.astype(np.float64)
        return np.hypot(diff[..., 0], diff[..., 1])


def summarize_endpoint_error(error: np.ndarray, mask: np.ndarray | None = None) -> dict[str, float]:
    """Mean and tail fractions of an :func:`endpoint_error_map` over ``mask``.

    ``mask`` defaults to the finite pixels of ``error``. Returns the dict of
    :func:`endpoint_error`.

    Raises
    ------
    MiketalkError
        For a mask of the wrong shape or type, an empty mask, or non-finite
        errors inside it.
    """
    if mask is None:
        mask = np.isfinite(error)
    else:
        mask = np.asarray(mask)
        if mask.shape != error.shape or mask.dtype != bool:
            raise MiketalkError(
                f"mask must be a boolean {error.shape} array, got {mask.dtype} {mask.shape}"
            )
    if not mask.any():
        raise MiketalkError("mask selects no pixels; nothing to score")
    epe = error[mask]
    if not np.isfinite(epe).all():
        raise MiketalkError("flow or true_flow holds NaN/inf inside the mask")
    return {
        "mean_epe": float(epe.mean()),
        "pct_over_1px": float(100.0 * (epe > 1.0).mean()),
        "pct_over_3px": float(100.0 * (epe > 3.0).mean()),
        "pixels": int(epe.size),
    }


def sinusoidal_pair(
    shape: tuple[int, int] = (256, 256), *, amplitude: float = 4.0, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A textured image pair with a known smooth flow, as scikit-image's flow tests build.

    ``B`` is seeded Gaussian-smoothed noise (sigma 1.5 px) scaled to [0, 1];
    the flow has ``dx = amplitude * sin(4 pi y / H)`` and
    ``dy = amplitude * cos(4 pi x / W)``; ``A = backward_warp(B, flow)``, so
    ``A(p) = B(p + flow(p))`` holds exactly (bilinear).

    Returns
    -------
    image_a, image_b : ndarray, shape (H, W), float32
    true_flow : ndarray, shape (H, W, 2), float32
    """
    h, w = shape
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), 1.5)
    image_b = (noise - noise.min()) / (noise.max() - noise.min())
    y, x = np.mgrid[:h, :w].astype(np.float32)
    true_flow = np.empty((h, w, 2), np.float32)
    true_flow[..., 0] = amplitude * np.sin(4 * np.pi * y / h)
    true_flow[..., 1] = amplitude * np.cos(4 * np.pi * x / w)
    return backward_warp(image_b, true_flow), image_b, true_flow


def motorcycle_pair() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """scikit-image's Middlebury 2014 motorcycle stereo pair as a flow problem.

    The left-to-right flow is ``(-disparity, 0)``: a left pixel at column
    ``x`` shows in the right image at ``x - d``.

    Returns
    -------
    left, right : ndarray, shape (H, W, 3), uint8
    true_flow : ndarray, shape (H, W, 2), float32
        ``(-disparity, 0)``; NaN where the disparity is unknown.
    valid : ndarray of bool, shape (H, W)
        Where the disparity is known (finite).
    """
    from skimage.data import stereo_motorcycle

    left, right, disparity = stereo_motorcycle()
    valid = np.isfinite(disparity)
    true_flow = np.zeros((*disparity.shape, 2), np.float32)
    true_flow[..., 0] = np.where(valid, -disparity, np.nan)
    true_flow[~valid, 1] = np.nan
    return left, right, true_flow, valid


def motorcycle_table(
    estimators: Iterable[str | Estimator] | None = None, *, threads: int | None = 1
) -> pd.DataFrame:
    """Run estimators on the motorcycle pair; one row each with EPE figures and time.

    Parameters
    ----------
    estimators : iterable of str or Estimator, optional
        Registry names or bound estimators; every registered one (default
        settings) by default.
    threads : int or None
        ``cv2.setNumThreads`` during the run (restored after); None leaves it.

    Returns
    -------
    pandas.DataFrame
        Columns ``estimator``, ``mean_epe``, ``pct_over_1px``, ``pct_over_3px``,
        ``seconds`` (wall time of one call), over the pixels of known disparity.
    """
    import pandas as pd

    left, right, true_flow, valid = motorcycle_pair()
    chosen = [
        get_estimator(e) if isinstance(e, str) else e
        for e in (ESTIMATORS if estimators is None else estimators)
    ]
    previous = cv2.getNumThreads()
    rows = []
    try:
        if threads is not None:
            cv2.setNumThreads(threads)
        for estimator in chosen:
            start = time.perf_counter()
            flow = estimator(left, right)
            seconds = time.perf_counter() - start
            scores = endpoint_error(flow, true_flow, valid)
            rows.append(
                {
                    "estimator": estimator.name,
                    "mean_epe": scores["mean_epe"],
                    "pct_over_1px": scores["pct_over_1px"],
                    "pct_over_3px": scores["pct_over_3px"],
                    "seconds": seconds,
                }
            )
    finally:
        cv2.setNumThreads(previous)
    return pd.DataFrame(rows)
