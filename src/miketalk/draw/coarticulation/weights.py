"""Dominance weights: each frame's visemes and how much of each (Cohen & Massaro 1993)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from miketalk.draw.coarticulation.params import CoarticulationParams
from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import Keyframe, Timeline


@dataclass(frozen=True)
class _Pairs:
    """(time, keyframe) pairs within the window: what the dominance is evaluated on."""

    time: np.ndarray  # index of the time of each pair
    viseme: np.ndarray  # index (into the viseme list) of the pair's keyframe
    offset: np.ndarray  # t - c_i, seconds
    n_times: int


def _pairs(
    centres: np.ndarray, viseme_index: np.ndarray, times: np.ndarray, window: float
) -> _Pairs:
    """Every keyframe within ``window`` of each time, and always the nearest one.

    In time order, keyframe order within a time. Sorted keyframes (a timeline's) are
    searched, so memory grows with the pairs, not with times x keyframes (an hour of
    speech has some 10^5 frames and 10^4 keyframes).
    """
    if len(centres) < 2 or np.any(np.diff(centres) < 0):
        offset = times[:, None] - centres[None, :]
        near = np.abs(offset) <= window
        near[np.arange(len(times)), np.argmin(np.abs(offset), axis=1)] = True
        t_idx, k_idx = np.nonzero(near)
        return _Pairs(t_idx, viseme_index[k_idx], offset[t_idx, k_idx], len(times))
    n = len(times)
    # the nearest keyframe: the first of the least distance, as argmin finds it
    right = np.clip(np.searchsorted(centres, times, side="left"), 1, len(centres) - 1)
    left = np.searchsorted(centres, centres[right - 1], side="left")
    nearest = np.where(np.abs(times - centres[right]) < np.abs(times - centres[left]), right, left)
    # the candidates within a widened window, then the exact test of the dense form
    lo = np.searchsorted(centres, times - window - 1e-6, side="left")
    hi = np.searchsorted(centres, times + window + 1e-6, side="right")
    counts = hi - lo
    t_idx = np.repeat(np.arange(n), counts)
    k_idx = np.repeat(lo, counts) + (
        np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    )
    keep = (np.abs(times[t_idx] - centres[k_idx]) <= window) | (k_idx == nearest[t_idx])
    t_idx, k_idx = t_idx[keep], k_idx[keep]
    outside = (nearest < lo) | (nearest >= hi)
    if outside.any():
        t_idx = np.concatenate([t_idx, np.flatnonzero(outside)])
        k_idx = np.concatenate([k_idx, nearest[outside]])
        order = np.lexsort((k_idx, t_idx))
        t_idx, k_idx = t_idx[order], k_idx[order]
    offset = times[t_idx] - centres[k_idx]
    return _Pairs(t_idx, viseme_index[k_idx], offset, n)


def _weights_of_pairs(
    pairs: _Pairs, log_a: np.ndarray, log_theta: np.ndarray, lead: float, n_visemes: int
) -> np.ndarray:
    """``(n_times, n_visemes)`` normalized weights from per-viseme log parameters."""
    # dominance in the log domain, shifted per time before exponentiating (no underflow)
    log_d = log_a[pairs.viseme] - np.exp(log_theta[pairs.viseme]) * np.abs(pairs.offset + lead)
    top = np.full(pairs.n_times, -np.inf)
    np.maximum.at(top, pairs.time, log_d)
    d = np.exp(log_d - top[pairs.time])
    weights = np.zeros((pairs.n_times, n_visemes))
    np.add.at(weights, (pairs.time, pairs.viseme), d)
    return weights / weights.sum(axis=1, keepdims=True)


def dominance_weights(
    keys: Sequence[Keyframe],
    times: np.ndarray | Sequence[float],
    params: CoarticulationParams,
) -> tuple[tuple[str, ...], np.ndarray]:
    """Every viseme's weight at each time (the untruncated blend of the module docstring).

    Parameters
    ----------
    keys : sequence of Keyframe
        The keyframes (:func:`miketalk.lipsync.timeline.keyframes`), at least one.
    times : array of float
        Seconds.
    params : CoarticulationParams
        Must know every keyframe's viseme.

    Returns
    -------
    (visemes, weights)
        The visemes of ``keys`` (first appearance order) and ``(len(times), len(visemes))``
        weights, each row summing to 1.
    """
    if not keys:
        raise MiketalkError("no keyframes to weigh")
    visemes = tuple(dict.fromkeys(k.viseme for k in keys))
    unknown = [v for v in visemes if v not in params.magnitude]
    if unknown:
        raise MiketalkError(f"coarticulation parameters lack viseme(s) {unknown}")
    index = {v: i for i, v in enumerate(visemes)}
    centres = np.array([k.time for k in keys], float)
    pairs = _pairs(
        centres,
        np.array([index[k.viseme] for k in keys]),
        np.asarray(times, float).reshape(-1),
        params.window,
    )
    log_a = np.log([params.magnitude[v] for v in visemes])
    log_theta = np.log([params.rate[v] for v in visemes])
    return visemes, _weights_of_pairs(pairs, log_a, log_theta, params.lead, len(visemes))


def _truncate(weights: np.ndarray, *, max_visemes: int, min_weight: float) -> np.ndarray:
    """Keep each row's ``max_visemes`` largest weights not under ``min_weight``; renormalize."""
    out = weights.copy()
    if weights.shape[1] > max_visemes:
        # the (n - max_visemes) smallest of each row are dropped
        drop = np.argpartition(weights, weights.shape[1] - max_visemes, axis=1)
        np.put_along_axis(out, drop[:, : weights.shape[1] - max_visemes], 0.0, axis=1)
    largest = out.max(axis=1, keepdims=True)
    out[(out < min_weight) & (out < largest)] = 0.0
    return out / out.sum(axis=1, keepdims=True)


def frame_weights(
    timeline: Timeline, params: CoarticulationParams
) -> list[tuple[tuple[str, float], ...]]:
    """Each frame's visemes and weights, as rendered.

    At most ``params.max_visemes`` visemes per frame, none under
    ``params.min_weight``, weights summing to 1, in the order of the time of
    each viseme's most dominant keyframe (so that a frame of two visemes names
    them as the paper's transition would: source first). A frame's time is its
    middle (a motion-blurred frame's samples are not used: the learned path is
    blurred by :func:`miketalk.draw.learned.learned_exposures`, which samples it again).
    """
    return weights_at(timeline, params, [f.time for f in timeline.frames])


def weights_at(
    timeline: Timeline, params: CoarticulationParams, times: Sequence[float] | np.ndarray
) -> list[tuple[tuple[str, float], ...]]:
    """The visemes and weights at each of ``times`` (seconds), as :func:`frame_weights`."""
    times = np.asarray(times, float).reshape(-1)
    visemes, weights = dominance_weights(timeline.keyframes, times, params)
    kept = _truncate(weights, max_visemes=params.max_visemes, min_weight=params.min_weight)
    # order: by the centre of the keyframe nearest in time among each viseme's keyframes
    centres = np.array([k.time for k in timeline.keyframes])
    key_visemes = np.array([visemes.index(k.viseme) for k in timeline.keyframes])
    out = []
    for t, row in zip(times, kept, strict=True):
        nonzero = np.flatnonzero(row)
        order = []
        for v in nonzero:
            own = centres[key_visemes == v]
            order.append((own[np.argmin(np.abs(own - t))], int(v)))
        out.append(tuple((visemes[v], float(row[v])) for _, v in sorted(order)))
    return out


def predict_trajectory(
    keys: Sequence[Keyframe],
    times: np.ndarray,
    params: CoarticulationParams,
    targets: Mapping[str, np.ndarray],
    *,
    rendered: bool = False,
) -> np.ndarray:
    """``sum_V w_V(t) E(V)``: the predicted coordinates ``(len(times), n)``.

    ``rendered=True`` uses the weights as rendered (:func:`frame_weights`'s truncation).
    """
    visemes, weights = dominance_weights(keys, times, params)
    if rendered:
        weights = _truncate(weights, max_visemes=params.max_visemes, min_weight=params.min_weight)
    return weights @ np.stack([targets[v] for v in visemes])


def paper_trajectory(timeline: Timeline, targets: Mapping[str, np.ndarray]) -> np.ndarray:
    """The paper's path in the same coordinates: ``(1 - alpha) E(source) + alpha E(target)``."""
    rows = []
    for f in timeline.frames:
        t = timeline.transitions[f.transition]
        rows.append((1.0 - f.alpha) * targets[t.source] + f.alpha * targets[t.target])
    return np.array(rows)
