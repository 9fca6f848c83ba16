"""Flow concatenation (the paper's Appendix: Eq. 11, Figs. 10 and 11).

Given frames ``I_0 ... I_n`` of a recording, consecutive flows ``C_{i(i+1)}``
are small enough for a gradient-based estimator; their concatenation
approximates the large ``C_{0n}``. Two flows cannot simply be added: they are
defined on different reference images. Eq. 11 first warps the second flow
backwards along the first, onto the first's reference image:

    C_{(i-1)(i+1)}(p) = C_{(i-1)i}(p) + C_{i(i+1)}(p + C_{(i-1)i}(p)).

CONCATENATION-UP (Fig. 11) grows ``C_{01}, C_{02}, ..., C_{0n}``, warping each
new small flow along the long one; CONCATENATION-DOWN (Fig. 10) grows
``C_{(n-1)n}, C_{(n-2)n}, ..., C_{0n}``, warping the long flow along each new
small one. In exact arithmetic both give the same ``C_{0n}``; with bilinear
interpolation DOWN resamples the accumulated field ``n - 1`` times and UP
resamples each consecutive flow once.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from miketalk.checks import check_flow
from miketalk.errors import MiketalkError
from miketalk.flow.warp import _remap, warp_in_box

FlowEstimator = Callable[[np.ndarray, np.ndarray], np.ndarray]

#: ``(x, y, w, h)``: a box outside which every flow of a chain is zero (flows estimated in
#: a region, :func:`~miketalk.flow.registry.in_region`).
Support = tuple[int, int, int, int]


def concat_flows(flow_ab: np.ndarray, flow_bc: np.ndarray) -> np.ndarray:
    """Concatenate ``C_ab`` and ``C_bc`` into ``C_ac`` (the paper's Eq. 11).

    ``C_ac(p) = C_ab(p) + C_bc(p + C_ab(p))``, the second term being
    ``backward_warp(C_bc, C_ab)`` (Fig. 9: bilinear, replicated borders).

    Parameters
    ----------
    flow_ab : ndarray, shape (H, W, 2)
        Flow from image A to image B (on A's grid).
    flow_bc : ndarray, shape (H, W, 2)
        Flow from image B to image C (on B's grid).

    Returns
    -------
    ndarray, shape (H, W, 2), float32
        Flow from A to C (on A's grid).

    Raises
    ------
    MiketalkError
        If the fields are not ``(H, W, 2)`` of one size or hold NaN/inf.

    Examples
    --------
    >>> import numpy as np
    >>> one = np.zeros((4, 5, 2), np.float32); one[..., 0] = 1.0
    >>> concat_flows(one, one)[0, 0].tolist()
    [2.0, 0.0]
    """
    flow_ab = check_flow(flow_ab, "flow_ab")
    flow_bc = check_flow(flow_bc, "flow_bc", flow_ab.shape[:2])
    return _concat(flow_ab, flow_bc)


def _concat(flow_ab: np.ndarray, flow_bc: np.ndarray, support: Support | None = None) -> np.ndarray:
    """``C_ac`` unchecked; with ``support``, computed in that box (:func:`concat_in_box`)."""
    if support is None:
        return flow_ab + _remap(flow_bc, flow_ab)
    inner = support_slices(support, flow_ab.shape)
    return whole_field(concat_in_box(flow_ab[inner], flow_bc, inner), inner, flow_ab.shape)


def consecutive_flows(frames: Sequence[np.ndarray], estimator: FlowEstimator) -> list[np.ndarray]:
    """The flows ``C_{i(i+1)}`` between consecutive frames, ``len(frames) - 1`` of them.

    Raises
    ------
    MiketalkError
        If there are fewer than two frames.
    """
    if len(frames) < 2:
        raise MiketalkError(f"frames must hold at least 2 images, got {len(frames)}")
    return [estimator(frames[i], frames[i + 1]) for i in range(len(frames) - 1)]


def _check_flows(flows: Sequence[np.ndarray]) -> list[np.ndarray]:
    if len(flows) < 1:
        raise MiketalkError("flows must hold at least 1 flow field")
    first = check_flow(flows[0], "flows[0]")
    return [first] + [
        check_flow(f, f"flows[{i}]", first.shape[:2]) for i, f in enumerate(flows[1:], 1)
    ]


def concatenate_up_flows(flows: Sequence[np.ndarray], support: Support | None = None) -> np.ndarray:
    """CONCATENATION-UP (Fig. 11) of precomputed consecutive flows into ``C_{0n}``.

    ``C_{0i} = C_{0(i-1)} + backward_warp(C_{(i-1)i}, C_{0(i-1)})`` for ``i = 2..n``.

    Parameters
    ----------
    flows : sequence of ndarray, shape (H, W, 2)
        ``C_{01}, C_{12}, ..., C_{(n-1)n}``.
    support : (x, y, w, h), optional
        A box outside which every flow is zero (estimated in a region). The chain is
        then zero there too, and only the box is computed (:func:`concat_in_box`): the
        same numbers, the work of the box's pixels.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
        ``C_{0n}``.
    """
    flows = _check_flows(flows)
    if support is not None:
        inner = support_slices(support, flows[0].shape)
        total = flows[0][inner].copy()
        for step in flows[1:]:
            total = concat_in_box(total, step, inner)
        return whole_field(total, inner, flows[0].shape)
    total = flows[0].copy()
    for step in flows[1:]:
        total = _concat(total, step)
    return total


def support_slices(support: Support, shape: tuple[int, ...]) -> tuple[slice, slice]:
    """The rows and columns of the box ``support`` ``(x, y, w, h)`` within ``shape``."""
    x, y, w, h = (int(v) for v in support)
    rows, cols = shape[:2]
    return slice(max(0, y), min(rows, y + h)), slice(max(0, x), min(cols, x + w))


def concat_in_box(total: np.ndarray, step: np.ndarray, inner: tuple[slice, slice]) -> np.ndarray:
    """:func:`concat_flows` over the box ``inner`` only: ``total`` is the first flow's box,
    ``step`` the whole second flow; the box of ``C_ac``, the same numbers as the whole.

    Outside a box where both flows are zero, ``C_ac(p) = 0 + C_bc(p) = 0``: a chain of flows
    zero outside one box is zero there too, so only the box is computed.
    """
    return total + warp_in_box(step, total, (inner[1].start, inner[0].start))


def whole_field(box: np.ndarray, inner: tuple[slice, slice], shape: tuple[int, ...]) -> np.ndarray:
    """The whole ``(H, W, 2)`` float32 flow of ``shape``: ``box`` over ``inner``, zero elsewhere."""
    out = np.zeros((*shape[:2], 2), np.float32)
    out[inner] = box
    return out


def concatenate_down_flows(
    flows: Sequence[np.ndarray], support: Support | None = None
) -> list[np.ndarray]:
    """CONCATENATION-DOWN (Fig. 10) of precomputed consecutive flows: every ``C_{in}``.

    ``C_{in} = C_{i(i+1)} + backward_warp(C_{(i+1)n}, C_{i(i+1)})`` for
    ``i = n-2 .. 0``. DOWN produces the flow from every frame to the last one
    on the way; they are all returned (the mixed strategy uses them).

    Parameters
    ----------
    flows : sequence of ndarray, shape (H, W, 2)
        ``C_{01}, C_{12}, ..., C_{(n-1)n}``.
    support : (x, y, w, h), optional
        A box outside which every flow is zero: computed there only, as
        :func:`concatenate_up_flows` does.

    Returns
    -------
    list of ndarray, shape (H, W, 2), float32
        ``[C_{0n}, C_{1n}, ..., C_{(n-1)n}]``: item ``i`` is the flow from frame
        ``i`` to frame ``n``. Item 0 is the concatenated flow ``C_{0n}``.
    """
    flows = _check_flows(flows)
    to_last = [flows[-1].copy()]
    for step in reversed(flows[:-1]):
        to_last.append(_concat(step, to_last[-1], support))
    to_last.reverse()
    return to_last


def concatenate_up(frames: Sequence[np.ndarray], estimator: FlowEstimator) -> np.ndarray:
    """``C_{0n}`` from frames ``I_0 .. I_n`` by CONCATENATION-UP (Fig. 11).

    Parameters
    ----------
    frames : sequence of ndarray
        Consecutive images ``I_0 .. I_n`` (n >= 1), all of one shape and dtype.
    estimator : callable
        ``estimator(image_a, image_b) -> flow``, e.g. from
        :func:`miketalk.flow.get_estimator`.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    return concatenate_up_flows(consecutive_flows(frames, estimator))


def concatenate_down(frames: Sequence[np.ndarray], estimator: FlowEstimator) -> np.ndarray:
    """``C_{0n}`` from frames ``I_0 .. I_n`` by CONCATENATION-DOWN (Fig. 10).

    Same parameters as :func:`concatenate_up`; the flows from the other frames
    to ``I_n`` are in :func:`concatenate_down_flows`.

    Returns
    -------
    ndarray, shape (H, W, 2), float32
    """
    return concatenate_down_flows(consecutive_flows(frames, estimator))[0]
