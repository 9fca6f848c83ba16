"""Super SloMo's linear approximation of the intermediate flow (Jiang et al. 2018, Eq. 4)."""

from __future__ import annotations

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.flow.warp import backward_warp


def slomo_flows(
    flow01: np.ndarray, flow10: np.ndarray, tau: float
) -> tuple[np.ndarray, np.ndarray]:
    """The intermediate flows of Super SloMo's linear approximation (Jiang et al. 2018, Eq. 4).

    ``F_t0 = -(1 - tau) tau F_01 + tau^2 F_10`` and
    ``F_t1 = (1 - tau)^2 F_01 - tau (1 - tau) F_10``: the flows from the
    frame at time ``tau`` back to frames 0 and 1, on the in-between frame's
    grid, assuming each pixel moves on a straight line at constant speed.

    Parameters
    ----------
    flow01, flow10 : ndarray, shape (H, W, 2)
        Flows from frame 0 to frame 1 and from frame 1 to frame 0 (our
        convention: ``I0(p) ~ I1(p + flow01(p))``).
    tau : float
        The in-between time in ``[0, 1]``.

    Returns
    -------
    flow_t0, flow_t1 : ndarray, shape (H, W, 2), float32
        ``I_tau(p) ~ I0(p + flow_t0(p)) ~ I1(p + flow_t1(p))``.

    Examples
    --------
    >>> import numpy as np
    >>> f01 = np.full((2, 2, 2), 4.0, np.float32)
    >>> f_t0, f_t1 = slomo_flows(f01, -f01, 0.25)
    >>> float(f_t0[0, 0, 0]), float(f_t1[0, 0, 0])
    (-1.0, 3.0)
    """
    tau = _check_tau(tau)
    f01 = np.asarray(flow01, np.float32)
    f10 = np.asarray(flow10, np.float32)
    if f01.shape != f10.shape or f01.ndim != 3 or f01.shape[2] != 2:
        raise MiketalkError(f"flows must both be (H, W, 2), got {f01.shape} and {f10.shape}")
    a, b = np.float32(tau), np.float32(1.0 - tau)
    flow_t0 = -(b * a) * f01 + (a * a) * f10
    flow_t1 = (b * b) * f01 - (a * b) * f10
    return flow_t0, flow_t1


def slomo_frame(
    image0: np.ndarray, image1: np.ndarray, flow01: np.ndarray, flow10: np.ndarray, tau: float
) -> np.ndarray:
    """The in-between frame at ``tau`` by backward warps along :func:`slomo_flows`.

    Both frames are warped backwards (bilinear,
    :func:`miketalk.flow.warp.backward_warp`) to time ``tau`` and blended with
    weights ``1 - tau`` and ``tau``: Super SloMo's Eq. 1 without its learned
    refinement and visibility maps.

    Parameters
    ----------
    image0, image1 : ndarray, shape (H, W) or (H, W, 3), uint8
        Frames 0 and 1.
    flow01, flow10 : ndarray, shape (H, W, 2)
        Flows between them, both ways.
    tau : float
        The in-between time in ``[0, 1]``.

    Returns
    -------
    ndarray
        uint8, the shape of ``image0`` (rounded half up).
    """
    if image0.shape != image1.shape:
        raise MiketalkError(f"image shapes differ: {image0.shape} vs {image1.shape}")
    flow_t0, flow_t1 = slomo_flows(flow01, flow10, tau)
    warp0 = backward_warp(image0, flow_t0).astype(np.float32)
    warp1 = backward_warp(image1, flow_t1).astype(np.float32)
    mixed = np.float32(1.0 - tau) * warp0 + np.float32(tau) * warp1
    return np.clip(np.floor(mixed + np.float32(0.5)), 0, 255).astype(np.uint8)


def _check_tau(tau: object) -> float:
    if isinstance(tau, bool) or not isinstance(tau, int | float | np.floating | np.integer):
        raise MiketalkError(f"tau must be a number in [0, 1], got {tau!r}")
    value = float(tau)
    if not 0.0 <= value <= 1.0:
        raise MiketalkError(f"tau must be in [0, 1], got {value}")
    return value
