"""What every flow strategy works with: a viseme pair, the recording, and its result.

A strategy is a plain function of a :class:`Pair` and the :class:`Recording`
the pair's frames come from; :mod:`miketalk.flow.build` runs it over every
pair in worker processes. :class:`Recording` holds what the strategies share:
the estimator, the frames (read lazily), the consecutive flows of the
recording (computed once, in shared memory-mapped arrays), the rest frames,
and chains cached per end frame.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from miketalk.flow.concat import (
    Support,
    concat_flows,
    concat_in_box,
    concatenate_up_flows,
    support_slices,
    whole_field,
)
from miketalk.flow.database import FlowDatabase
from miketalk.flow.mixed import window_chains
from miketalk.media.images import read_image


@dataclass(frozen=True)
class Pair:
    """Two visemes, their images and the recording frames they were taken from."""

    source: str
    target: str
    image_a: np.ndarray
    image_b: np.ndarray
    frame_a: int
    frame_b: int


@dataclass
class PairFlows:
    """A pair's flows both ways and what the strategy chose (intermediate frames, residuals)."""

    forward: np.ndarray
    backward: np.ndarray
    info: dict = field(default_factory=dict)


@dataclass
class Recording:
    """The recording a viseme set was taken from, as the strategies see it.

    Attributes
    ----------
    estimate : callable
        ``estimate(image_a, image_b) -> flow``.
    frames_dir : Path
        The corpus frames (``frame_name(k)`` for frame ``k``).
    n_frames : int
        Frames in the recording.
    window : int
        Frames before the end viseme's frame searched by the mixed strategy.
    mask : (H, W) bool, optional
        Where the mixed and bridge strategies measure their residual.
    consecutive : (forward, backward), optional
        ``forward[slots[k]]`` is the flow from frame k to k+1,
        ``backward[slots[k]]`` from k+1 to k, for the ``k`` a strategy asked for.
    slots : dict
        ``k -> row`` of ``consecutive``.
    rest : ndarray of int, optional
        The rest frames (bridge).
    mixed : FlowDatabase, optional
        The mixed database of the same method, which the bridge refines.
    viseme_frames : tuple of int
        The frames the visemes were taken from (where chains end).
    support : (x, y, w, h), optional
        The region the flows are estimated in (zero outside): chains are computed there.
    """

    estimate: Callable[[np.ndarray, np.ndarray], np.ndarray]
    frames_dir: Path
    n_frames: int
    window: int = 6
    mask: np.ndarray | None = None
    consecutive: tuple[np.ndarray, np.ndarray] | None = None
    slots: dict[int, int] = field(default_factory=dict)
    rest: np.ndarray | None = None
    mixed: FlowDatabase | None = None
    viseme_frames: tuple[int, ...] = ()
    support: Support | None = None
    _frames: dict[int, np.ndarray] = field(default_factory=dict, repr=False)
    _chains: dict[int, list[np.ndarray]] = field(default_factory=dict, repr=False)
    _folds: dict[int, dict[int, np.ndarray]] = field(default_factory=dict, repr=False)
    _prefixes: dict[tuple[int, int], np.ndarray] = field(default_factory=dict, repr=False)

    def frame(self, index: int) -> np.ndarray:
        """Frame ``index`` of the recording (read once, then cached)."""
        from miketalk.corpus.folder import frame_path

        if index not in self._frames:
            self._frames[index] = read_image(frame_path(self.frames_dir, index))
        return self._frames[index]

    def steps(self, start: int, end: int) -> list[np.ndarray]:
        """The consecutive flows of the recording from frame ``start`` to frame ``end``."""
        if end >= start:
            return [self.step(k, 1) for k in range(start, end)]
        return [self.step(k, -1) for k in range(start, end, -1)]

    def step(self, k: int, sign: int) -> np.ndarray:
        """The consecutive flow from frame ``k`` to ``k + sign`` (sign 1 or -1)."""
        forward, backward = self.consecutive
        return forward[self.slots[k]] if sign > 0 else backward[self.slots[k - 1]]

    def chain(self, flows: Sequence[np.ndarray], like: int) -> np.ndarray:
        """CONCATENATION-UP of ``flows``; zero flow (frame ``like``'s size) when empty."""
        if not flows:
            return np.zeros((*self.frame(like).shape[:2], 2), np.float32)
        return concatenate_up_flows(list(flows), self.support)

    def fold_of_steps(self, start: int, end: int) -> np.ndarray | None:
        """The chain of consecutive flows from frame ``start`` to ``end`` (None: the same frame).

        Cached by ``(start, end)``: a start frame meets the same rest frame in
        every pair it is in.
        """
        if start == end:
            return None
        key = (start, end)
        if key not in self._prefixes:
            self._prefixes[key] = concatenate_up_flows(self.steps(start, end), self.support)
        return self._prefixes[key]

    def fold_from(self, start: int) -> dict[int, np.ndarray]:
        """Chains from frame ``start`` to every other viseme frame, in one pass each way.

        CONCATENATION-UP over the consecutive flows, forward in time for the
        later viseme frames and backward for the earlier ones.
        ``C_{s,k+1} = C_{s,k} + C_{k,k+1}(p + C_{s,k}(p))`` is a left fold, so each
        end's chain is the fold's value when it reaches that frame: the same
        numbers as :meth:`chain` of that end's steps alone, for one pass per
        direction instead of one per end.
        """
        if start in self._folds:
            return self._folds[start]
        out: dict[int, np.ndarray] = {}
        later = sorted(e for e in set(self.viseme_frames) if e > start)
        earlier = sorted((e for e in set(self.viseme_frames) if e < start), reverse=True)
        shape = self.frame(start).shape
        inner = None if self.support is None else support_slices(self.support, shape)
        for targets, sign in ((later, 1), (earlier, -1)):
            total, k = None, start
            for end in targets:
                while k != end:
                    step = np.asarray(self.step(k, sign))
                    if inner is not None:
                        total = (
                            step[inner].copy()
                            if total is None
                            else concat_in_box(total, step, inner)
                        )
                    else:
                        total = step.copy() if total is None else concat_flows(total, step)
                    k += sign
                out[end] = total if inner is None else whole_field(total, inner, shape)
        self._folds[start] = out
        return out

    def chains_to(self, end: int) -> list[np.ndarray]:
        """:func:`~miketalk.flow.mixed.window_chains` to frame ``end``, once per end frame."""
        if end not in self._chains:
            self._chains[end] = window_chains(
                _LazyFrames(self), end, self.estimate, window=self.window, support=self.support
            )
        return self._chains[end]

    def lazy_frames(self) -> Sequence[np.ndarray]:
        """The frames as a sequence read on access (the mixed search touches only its window)."""
        return _LazyFrames(self)


class _LazyFrames(Sequence):
    def __init__(self, recording: Recording) -> None:
        self._recording = recording

    def __len__(self) -> int:
        return self._recording.n_frames

    def __getitem__(self, index):  # type: ignore[override]
        return self._recording.frame(int(index))


#: ``pair_flows(pair, recording) -> PairFlows``: one pair, run in a worker.
PairFunction = Callable[[Pair, Recording], PairFlows]


@dataclass(frozen=True)
class Strategy:
    """A flow strategy: its per-pair function and the recording it needs.

    Attributes
    ----------
    name : str
        What ``config.yaml`` calls it (``flow.strategy``).
    pair_flows : callable
        ``(Pair, Recording) -> PairFlows``.
    steps : callable
        ``(viseme_frames, n_frames, rest) -> list of k``: the consecutive flows
        ``k -> k+1`` (and back) it reads, computed once before the pairs.
    needs_rest : bool
        Whether it passes through the recording's rest frames.
    refines : str or None
        The strategy whose database of the same method it starts from.
    contiguous : bool
        Hand the pairs to the workers in contiguous blocks rather than one at a
        time (its per-pair function caches work per start frame).
    """

    name: str
    pair_flows: PairFunction
    steps: Callable[[Sequence[int], int, np.ndarray | None], list[int]]
    needs_rest: bool = False
    refines: str | None = None
    contiguous: bool = False


def no_steps(frames: Sequence[int], n_frames: int, rest: np.ndarray | None) -> list[int]:
    """A strategy that reads no consecutive flows."""
    return []
