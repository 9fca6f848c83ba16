"""Which of a pool's GRID clips a held-out bench trains on and which it tests on."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["draw_training", "split_clips"]


def split_clips(pool_ids: Sequence[str], train_order: Sequence[str], test_order: Sequence[str],
                n_train: int, n_test: int) -> tuple[list[str], list[str]]:  # fmt: skip
    """``n_train`` training and ``n_test`` test clips, never the same clip in both: the test
    clips ``test_order``'s first ones, then the pool's others (name order) that no training
    list names; the training clips ``train_order``'s first ones, then the pool's remaining
    clips in name order. A pool too small is a :class:`MiketalkError`."""
    pool = sorted(set(pool_ids))
    known = set(pool)
    test = [c for c in test_order if c in known][:n_test]
    spare = [c for c in pool if c not in set(train_order) and c not in set(test)]
    test += spare[: n_test - len(test)]
    train = [c for c in train_order if c in known and c not in set(test)][:n_train]
    rest = [c for c in pool if c not in set(train) and c not in set(test)]
    train += rest[: n_train - len(train)]
    if len(train) < n_train or len(test) < n_test:
        raise MiketalkError(
            f"the pool has {len(pool)} clips: not enough for {n_train} training and "
            f"{n_test} test clips"
        )
    return train, test


def draw_training(pool_ids: Sequence[str], test: Sequence[str], n_train: int,
                  draw: int) -> list[str]:  # fmt: skip
    """Training draw ``draw`` (at least 1): ``n_train`` of the pool's clips that are not
    test clips, in the order of a permutation seeded by ``draw`` (the same draw, the same
    clips on any machine). Draws differ in the clips trained on, not in the test clips,
    so that models of several draws are measured on the same clips.

    Parameters
    ----------
    pool_ids : sequence of str
        The pool's clip names.
    test : sequence of str
        The test clips, never drawn.
    n_train : int
        How many clips to draw.
    draw : int
        The draw's number, the permutation's seed; 0 is kept for the config's own order
        (:func:`split_clips`) and is refused here.
    """
    if draw < 1:
        raise MiketalkError(f"training draw {draw}: a draw is numbered from 1")
    rest = sorted(set(pool_ids) - set(test))
    if len(rest) < n_train:
        raise MiketalkError(
            f"the pool has {len(rest)} clips besides the test clips: not enough for "
            f"{n_train} training clips"
        )
    order = np.random.default_rng(draw).permutation(len(rest))
    return [rest[k] for k in order[:n_train]]
