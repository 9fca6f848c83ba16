"""Audio alignment: the DTW path and the time map built on it."""

from __future__ import annotations

import numpy as np
import pytest

from miketalk.speech.audio_align import _dtw_path, dtw_map, map_times


def _brute_force_cost(cost: np.ndarray) -> float:
    """Smallest total cost of a monotone path from (0, 0) to (n-1, m-1), by recursion."""
    n, m = cost.shape
    acc = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(m):
            prev = [acc[i - 1, j - 1] if i and j else np.inf, acc[i - 1, j] if i else np.inf]
            prev.append(acc[i, j - 1] if j else np.inf)
            acc[i, j] = cost[i, j] + (0.0 if i == j == 0 else min(prev))
    return float(acc[-1, -1])


@pytest.mark.parametrize("seed", range(5))
def test_dtw_path_is_a_monotone_path_of_least_cost(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, m = (int(v) for v in rng.integers(1, 25, 2))
    cost = rng.random((n, m))
    path = _dtw_path(cost)
    assert tuple(path[0]) == (0, 0) and tuple(path[-1]) == (n - 1, m - 1)
    steps = np.diff(path, axis=0)
    assert ((steps >= 0) & (steps <= 1)).all() and (steps.sum(axis=1) >= 1).all()
    assert cost[path[:, 0], path[:, 1]].sum() == pytest.approx(_brute_force_cost(cost))


def test_dtw_prefers_the_diagonal_on_ties() -> None:
    np.testing.assert_array_equal(_dtw_path(np.zeros((4, 4))), [[i, i] for i in range(4)])


def test_dtw_map_recovers_a_time_stretch() -> None:
    # the query is the reference played at half speed: frame i matches frame 2 i
    t = np.linspace(0, 1, 60)
    reference = np.stack([np.sin(7 * t), np.cos(3 * t), t**2], axis=1)
    query = np.repeat(reference, 2, axis=0)
    mapping = dtw_map(reference, query)
    assert np.abs(mapping - (2 * np.arange(60) + 0.5)).max() <= 1.0


def test_map_times_is_the_identity_for_the_same_audio() -> None:
    rng = np.random.default_rng(1)
    rate = 16000
    envelope = np.repeat(rng.random(40), rate // 40)
    audio = (8000 * envelope * np.sin(np.arange(rate) * 0.3)).astype(np.int16)
    to_recorded = map_times(audio, rate, audio, rate)
    times = np.array([0.1, 0.35, 0.5, 0.8])
    np.testing.assert_allclose(to_recorded(times), times, atol=0.011)
