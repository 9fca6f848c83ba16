"""The paper's mixed strategy (section 5.2): a direct flow, then a concatenated one.

For visemes far apart in the recording, concatenating hundreds of consecutive
flows degrades the result, and a direct flow fails when the shapes differ too
much. The paper picks "an intermediate frame ... that is simultaneously similar
in shape to the chosen starting viseme, and also close in distance to the
chosen ending viseme", computes the direct flow from the start viseme to that
frame, the concatenated flow from it to the end viseme, and concatenates both.

Our criterion for the intermediate frame ``j``
---------------------------------------------
Candidates are the ``window`` frames before the end frame and the end frame
itself, ``j`` in ``[end - window, end]`` (``j = end`` is the pure direct flow).
For each one we build the full candidate flow

    F_j = concat(C_{start, j}, C_{j, end}),

with ``C_{start, j}`` estimated directly and ``C_{j, end}`` by
CONCATENATION-DOWN (Fig. 10), which yields ``C_{j, end}`` for every ``j`` of
the window in one pass. ``F_j`` is judged by what it is for: it should carry
the end viseme onto the start viseme. The score is

    score(j) = mean_{p in mask} |S(p) - E(p + F_j(p))|  +  penalty * (end - j),

the mean absolute grey-level residual (0-1 scale) of the start image ``S``
against the end image ``E`` warped backwards along ``F_j`` over the mouth
region, plus a charge per concatenated flow. The residual is low when the
direct flow found the shapes alike (similar in shape) and the chain stayed
accurate; the charge, ``penalty``, prefers the shorter chain (close to the end
viseme) when residuals tie, because photometric residuals do not see all
concatenation drift (flat regions match whatever the flow). The chosen ``j``
minimises the score; ties go to the larger ``j``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from miketalk.checks import check_image, to_grey_float32
from miketalk.errors import MiketalkError
from miketalk.flow.concat import Support, _concat, concatenate_down_flows, consecutive_flows
from miketalk.flow.warp import warp_in_box

FlowEstimator = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class MixedFlowInfo:
    """How :func:`mixed_flow` chose its intermediate frame.

    Attributes
    ----------
    index : int
        The chosen intermediate frame ``j``.
    score : float
        Its score (residual + penalty * (end - j)).
    candidates : tuple of int
        Every ``j`` considered, ascending.
    residuals : tuple of float
        Mean absolute residual of ``F_j`` over the mask, per candidate.
    scores : tuple of float
        Score per candidate.
    """

    index: int
    score: float
    candidates: tuple[int, ...]
    residuals: tuple[float, ...]
    scores: tuple[float, ...]


def mixed_flow(
    start_image: np.ndarray,
    frames: Sequence[np.ndarray],
    end_index: int,
    estimator: FlowEstimator,
    *,
    window: int = 8,
    penalty: float = 0.0005,
    mask: np.ndarray | None = None,
    chains: Sequence[np.ndarray] | None = None,
    support: Support | None = None,
) -> tuple[np.ndarray, MixedFlowInfo]:
    """Flow from a start viseme to ``frames[end_index]`` by the mixed strategy (section 5.2).

    Parameters
    ----------
    start_image : ndarray, shape (H, W) or (H, W, 3)
        The starting viseme image.
    frames : sequence of ndarray
        The recorded frames, same shape and dtype as ``start_image``.
    end_index : int
        Index in ``frames`` of the ending viseme's frame.
    estimator : callable
        ``estimator(image_a, image_b) -> flow``, used for the direct flows and
        the consecutive flows.
    window : int
        How many frames before ``end_index`` are candidates (fewer near the
        start of the recording); 0 gives the pure direct flow.
    penalty : float
        Score charged per concatenated flow, in mean absolute grey levels
        (0-1 scale) per frame.
    mask : ndarray of bool, shape (H, W), optional
        Region where the residual is measured (the mouth); everywhere by default.
    chains : sequence of ndarray, optional
        :func:`window_chains` of the same ``frames``, ``end_index``, ``estimator``
        and ``window``, when several start visemes share one end viseme (they
        are computed here otherwise).
    support : (x, y, w, h), optional
        A box outside which the estimator's flows are zero (estimated in a region):
        the concatenations are computed there only, with the same numbers.

    Returns
    -------
    flow : ndarray, shape (H, W, 2), float32
        ``F_j`` for the chosen ``j``: from ``start_image`` to ``frames[end_index]``.
    info : MixedFlowInfo
        The chosen ``j``, its score, and every candidate's residual and score.

    Raises
    ------
    MiketalkError
        For an ``end_index`` outside ``frames``, a bad ``window``, ``penalty``
        or ``mask``, or images of different shapes or dtypes.
    """
    start = check_image(start_image, "start_image")
    if not isinstance(end_index, int | np.integer) or not 0 <= end_index < len(frames):
        raise MiketalkError(
            f"end_index must index frames (0 to {len(frames) - 1}), got {end_index!r}"
        )
    if not isinstance(window, int | np.integer) or window < 0:
        raise MiketalkError(f"window must be an integer >= 0, got {window!r}")
    if not penalty >= 0:
        raise MiketalkError(f"penalty must be >= 0, got {penalty!r}")
    first = max(0, int(end_index) - int(window))
    candidates = list(range(first, int(end_index) + 1))
    for j in candidates:
        frame = check_image(frames[j], f"frames[{j}]")
        if frame.shape != start.shape or frame.dtype != start.dtype:
            raise MiketalkError(
                f"frames[{j}] is {frame.shape} {frame.dtype} but start_image is "
                f"{start.shape} {start.dtype}; give them one shape and dtype"
            )
    if mask is None:
        mask = np.ones(start.shape[:2], bool)
    else:
        mask = np.asarray(mask)
        if mask.shape != start.shape[:2] or mask.dtype != bool or not mask.any():
            raise MiketalkError(
                f"mask must be a boolean {start.shape[:2]} array with some True pixels, "
                f"got {mask.dtype} {mask.shape}"
            )

    if chains is None:
        chains = window_chains(frames, end_index, estimator, window=window, support=support)
    elif len(chains) != len(candidates) - 1:
        raise MiketalkError(
            f"chains must hold {len(candidates) - 1} flows (window_chains of the same "
            f"end_index and window), got {len(chains)}"
        )
    start_grey = to_grey_float32(start)
    end_grey = to_grey_float32(np.asarray(frames[end_index]))

    flows, residuals, scores = [], [], []
    for k, j in enumerate(candidates):
        direct = estimator(start, frames[j])
        flow = direct if j == end_index else _concat(direct, chains[k], support)
        residual = _residual(start_grey, end_grey, flow, mask)
        flows.append(flow)
        residuals.append(residual)
        scores.append(residual + penalty * (end_index - j))
    # argmin of the scores; among equal scores the last (the shortest chain)
    best = len(scores) - 1 - int(np.argmin(scores[::-1]))
    info = MixedFlowInfo(
        index=candidates[best],
        score=scores[best],
        candidates=tuple(candidates),
        residuals=tuple(residuals),
        scores=tuple(scores),
    )
    return flows[best], info


def window_chains(
    frames: Sequence[np.ndarray],
    end_index: int,
    estimator: FlowEstimator,
    *,
    window: int,
    support: Support | None = None,
) -> list[np.ndarray]:
    """Concatenated flows ``C_{j, end}`` from each window frame ``j < end`` to the end frame.

    CONCATENATION-DOWN (Fig. 10) over the consecutive flows of frames
    ``end - window .. end``: item ``k`` is the flow from frame
    ``max(0, end - window) + k`` to ``frames[end_index]``. Empty for a window of
    one frame. They depend only on the end frame, so every start viseme of one
    end viseme can share them (:func:`mixed_flow`'s ``chains``).
    With ``support``, computed in that box (:func:`mixed_flow`).
    """
    first = max(0, int(end_index) - int(window))
    window_frames = [frames[j] for j in range(first, int(end_index) + 1)]
    if len(window_frames) < 2:
        return []
    return concatenate_down_flows(consecutive_flows(window_frames, estimator), support)


def warp_residual(
    start_image: np.ndarray, end_image: np.ndarray, flow: np.ndarray, mask: np.ndarray | None
) -> float:
    """Mean absolute grey-level residual (0-1 scale) of ``start`` against ``end`` warped back.

    ``mean_{p in mask} |S(p) - E(p + flow(p))|``: how well ``flow`` carries the
    end image onto the start image, the criterion :func:`mixed_flow` chooses by.
    """
    start, end = (
        to_grey_float32(check_image(start_image, "start_image")),
        to_grey_float32(check_image(end_image, "end_image")),
    )
    if mask is None:
        mask = np.ones(start.shape, bool)
    return _residual(start, end, flow, mask)


def _residual(start: np.ndarray, end: np.ndarray, flow: np.ndarray, mask: np.ndarray) -> float:
    """The residual over ``mask``, ``end`` warped over the mask's bounding box only (the
    same pixels in the same order: the same mean)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not rows.size:
        return float("nan")  # nothing to measure (mixed_flow refuses such a mask)
    inner = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    warped = warp_in_box(end, flow[inner], (cols[0], rows[0]))
    return float(np.abs(start[inner] - warped)[mask[inner]].mean())
