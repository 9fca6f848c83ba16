"""OpenCV's flow estimators behind our signature ``estimator(image_a, image_b, **settings)``.

They serve as references for :func:`miketalk.flow.bergen.bergen_flow`: DIS
(Kroeger et al. 2016), Farneback (2003), DeepFlow (Weinzaepfel et al. 2013)
and TV-L1 (Zach et al. 2007). Each converts its inputs to 8-bit grey, as all of
them accept it, and returns the flow in our convention (which is OpenCV's):
``image_a(p) ~ image_b(p + flow(p))``, ``[..., 0]`` = dx, ``[..., 1]`` = dy.

OpenCV may run these on several threads; their results were found
bit-identical for 1, 2 and 8 threads (``cv2.setNumThreads``), so the thread
count is left to the caller.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import cv2
import numpy as np

from miketalk.checks import check_pair, to_grey_uint8
from miketalk.errors import MiketalkError

DIS_PRESETS = {
    "ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
    "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
    "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
}


def _grey_pair(image_a: np.ndarray, image_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = check_pair(image_a, image_b)
    return to_grey_uint8(a), to_grey_uint8(b)


def _as_flow(flow: np.ndarray, name: str) -> np.ndarray:
    flow = np.ascontiguousarray(flow, dtype=np.float32)
    if not np.isfinite(flow).all():
        raise MiketalkError(f"OpenCV {name} returned NaN/inf flow; check its settings")
    return flow


def _is_int(value: object, low: int) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool) and value >= low


def _require(ok: bool, estimator: str, setting: str, value: object, what: str) -> None:
    if not ok:
        raise MiketalkError(f"{estimator} setting {setting} must be {what}, got {value!r}")


def check_dis_settings(
    *,
    preset: str,
    finest_scale: int | None,
    patch_size: int | None,
    patch_stride: int | None,
    gradient_descent_iterations: int | None,
    variational_refinement_iterations: int | None,
) -> None:
    """Raise MiketalkError for a bad :func:`dis_flow` setting (OpenCV would crash on some)."""
    if preset not in DIS_PRESETS:
        raise MiketalkError(f"unknown DIS preset {preset!r}; use one of {sorted(DIS_PRESETS)}")
    lows = {
        "finest_scale": (finest_scale, 0),
        "patch_size": (patch_size, 1),
        "patch_stride": (patch_stride, 1),
        "gradient_descent_iterations": (gradient_descent_iterations, 0),
        "variational_refinement_iterations": (variational_refinement_iterations, 0),
    }
    for setting, (value, low) in lows.items():
        ok = value is None or _is_int(value, low)
        _require(ok, "DIS", setting, value, f"None or an integer >= {low}")


def check_farneback_settings(
    *,
    pyr_scale: float,
    levels: int,
    winsize: int,
    iterations: int,
    poly_n: int,
    poly_sigma: float,
    gaussian: bool,
) -> None:
    """Raise MiketalkError for a bad :func:`farneback_flow` setting."""
    _require(0 < pyr_scale < 1, "farneback", "pyr_scale", pyr_scale, "in (0, 1)")
    for setting, value in (("levels", levels), ("winsize", winsize), ("iterations", iterations)):
        _require(_is_int(value, 1), "farneback", setting, value, "an integer >= 1")
    _require(poly_n in (5, 7), "farneback", "poly_n", poly_n, "5 or 7")
    _require(poly_sigma > 0, "farneback", "poly_sigma", poly_sigma, "> 0")
    _require(isinstance(gaussian, bool), "farneback", "gaussian", gaussian, "true or false")


def check_tvl1_settings(
    *,
    attachment: float,
    tightness: float,
    tau: float,
    nscales: int,
    scale_step: float,
    warps: int,
    epsilon: float,
    inner_iterations: int,
    outer_iterations: int,
    median_filtering: int,
) -> None:
    """Raise MiketalkError for a bad :func:`tvl1_flow` setting."""
    for setting, value in (
        ("attachment", attachment),
        ("tightness", tightness),
        ("tau", tau),
        ("epsilon", epsilon),
    ):
        _require(value > 0, "tvl1", setting, value, "> 0")
    _require(0 < scale_step < 1, "tvl1", "scale_step", scale_step, "in (0, 1)")
    for setting, value in (
        ("nscales", nscales),
        ("warps", warps),
        ("inner_iterations", inner_iterations),
        ("outer_iterations", outer_iterations),
    ):
        _require(_is_int(value, 1), "tvl1", setting, value, "an integer >= 1")
    _require(
        median_filtering in (1, 3, 5), "tvl1", "median_filtering", median_filtering, "1, 3 or 5"
    )


@contextlib.contextmanager
def _opencv_errors(name: str, **settings: object) -> Iterator[None]:
    """Turn an OpenCV error (a bad setting, mostly) into a MiketalkError naming the estimator."""
    try:
        yield
    except cv2.error as err:
        listed = ", ".join(f"{k}={v!r}" for k, v in settings.items()) or "defaults"
        raise MiketalkError(f"OpenCV {name} failed with settings {listed}: {err}") from err


def dis_flow(
    image_a: np.ndarray,
    image_b: np.ndarray,
    *,
    preset: str = "medium",
    finest_scale: int | None = None,
    patch_size: int | None = None,
    patch_stride: int | None = None,
    gradient_descent_iterations: int | None = None,
    variational_refinement_iterations: int | None = None,
) -> np.ndarray:
    """Dense Inverse Search flow (``cv2.DISOpticalFlow``).

    Parameters
    ----------
    image_a, image_b : ndarray
        Grey or RGB images, same shape and dtype (uint8 or float in 0-1).
    preset : {"ultrafast", "fast", "medium"}
        OpenCV's preset; the other settings override single values of it.
    finest_scale, patch_size, patch_stride, gradient_descent_iterations, \
variational_refinement_iterations : int, optional
        The ``cv2.DISOpticalFlow`` setters of the same names.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    check_dis_settings(
        preset=preset,
        finest_scale=finest_scale,
        patch_size=patch_size,
        patch_stride=patch_stride,
        gradient_descent_iterations=gradient_descent_iterations,
        variational_refinement_iterations=variational_refinement_iterations,
    )
    a, b = _grey_pair(image_a, image_b)
    overrides = {
        "setFinestScale": finest_scale,
        "setPatchSize": patch_size,
        "setPatchStride": patch_stride,
        "setGradientDescentIterations": gradient_descent_iterations,
        "setVariationalRefinementIterations": variational_refinement_iterations,
    }
    with _opencv_errors("DIS", preset=preset, **{k[3:]: v for k, v in overrides.items()}):
        dis = cv2.DISOpticalFlow_create(DIS_PRESETS[preset])
        for setter, value in overrides.items():
            if value is not None:
                getattr(dis, setter)(int(value))
        flow = dis.calc(a, b, None)
    return _as_flow(flow, "DIS")


def farneback_flow(
    image_a: np.ndarray,
    image_b: np.ndarray,
    *,
    pyr_scale: float = 0.5,
    levels: int = 5,
    winsize: int = 15,
    iterations: int = 3,
    poly_n: int = 5,
    poly_sigma: float = 1.2,
    gaussian: bool = False,
) -> np.ndarray:
    """Farneback's polynomial-expansion flow (``cv2.calcOpticalFlowFarneback``).

    The settings are that function's arguments; ``gaussian`` sets
    ``OPTFLOW_FARNEBACK_GAUSSIAN``. OpenCV stops the pyramid before its levels
    get small: on the ~500x740 motorcycle pair ``levels=3`` and ``levels=5``
    give the same flow, and its 40-60 pixel disparities are out of reach.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    check_farneback_settings(
        pyr_scale=pyr_scale,
        levels=levels,
        winsize=winsize,
        iterations=iterations,
        poly_n=poly_n,
        poly_sigma=poly_sigma,
        gaussian=gaussian,
    )
    a, b = _grey_pair(image_a, image_b)
    flags = cv2.OPTFLOW_FARNEBACK_GAUSSIAN if gaussian else 0
    with _opencv_errors("Farneback", pyr_scale=pyr_scale, levels=levels, winsize=winsize):
        flow = cv2.calcOpticalFlowFarneback(
            a, b, None, float(pyr_scale), int(levels), int(winsize), int(iterations),
            int(poly_n), float(poly_sigma), flags,
        )  # fmt: skip
    return _as_flow(flow, "Farneback")


def deepflow_flow(image_a: np.ndarray, image_b: np.ndarray) -> np.ndarray:
    """DeepFlow (``cv2.optflow.createOptFlow_DeepFlow``), OpenCV's default settings.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    a, b = _grey_pair(image_a, image_b)
    with _opencv_errors("DeepFlow"):
        flow = cv2.optflow.createOptFlow_DeepFlow().calc(a, b, None)
    return _as_flow(flow, "DeepFlow")


def tvl1_flow(
    image_a: np.ndarray,
    image_b: np.ndarray,
    *,
    attachment: float = 0.15,
    tightness: float = 0.3,
    tau: float = 0.25,
    nscales: int = 6,
    scale_step: float = 0.5,
    warps: int = 5,
    epsilon: float = 0.01,
    inner_iterations: int = 30,
    outer_iterations: int = 10,
    median_filtering: int = 5,
) -> np.ndarray:
    """Dual TV-L1 flow (``cv2.optflow.DualTVL1OpticalFlow``).

    Parameters
    ----------
    attachment : float
        Weight of the data term (OpenCV's ``lambda``).
    tightness : float
        Coupling of the two flow variables (OpenCV's ``theta``).
    tau, nscales, scale_step, warps, epsilon, inner_iterations, outer_iterations, \
median_filtering
        OpenCV's settings of the same names. ``nscales=6, scale_step=0.5``
        differ from OpenCV's ``5, 0.8``, whose coarsest level is too fine for
        motions of tens of pixels.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    check_tvl1_settings(
        attachment=attachment,
        tightness=tightness,
        tau=tau,
        nscales=nscales,
        scale_step=scale_step,
        warps=warps,
        epsilon=epsilon,
        inner_iterations=inner_iterations,
        outer_iterations=outer_iterations,
        median_filtering=median_filtering,
    )
    a, b = _grey_pair(image_a, image_b)
    settings = {
        "tau": tau,
        "lambda_": attachment,
        "theta": tightness,
        "nscales": int(nscales),
        "warps": int(warps),
        "epsilon": epsilon,
        "innnerIterations": int(inner_iterations),  # sic: OpenCV's spelling
        "outerIterations": int(outer_iterations),
        "scaleStep": scale_step,
        "medianFiltering": int(median_filtering),
    }
    with _opencv_errors("TV-L1", **settings):
        flow = cv2.optflow.DualTVL1OpticalFlow_create(**settings).calc(a, b, None)
    return _as_flow(flow, "TV-L1")
