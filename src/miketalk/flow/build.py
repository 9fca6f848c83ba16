"""The flow database of a viseme set: every pair's flows by one strategy, over worker processes.

The strategies themselves are plain functions in :mod:`miketalk.flow.strategies`;
this module only prepares the :class:`~miketalk.flow.strategies.Recording`
they share (the consecutive flows they need, computed once into memory-mapped
arrays every worker reads), spreads the pairs over a process pool and writes
each pair's OpenEXR file (forward and backward layers) from the worker that
made it. Results do not depend on the number of workers.
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Sequence
from itertools import combinations
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from miketalk.corpus.folder import count_frames, frame_path
from miketalk.corpus.rest import rest_frames
from miketalk.errors import MiketalkError
from miketalk.flow.database import FlowDatabase, pair_path
from miketalk.flow.exr import write_flow_pair
from miketalk.flow.registry import get_estimator, in_region
from miketalk.flow.strategies import Pair, Recording, Strategy, get_strategy
from miketalk.media.images import read_image
from miketalk.workers import map_in_pool, process_pool

log = logging.getLogger(__name__)

# The worker process's recording and what it writes, set by _init_worker (a process
# pool's initializer can only hand state to its tasks through the worker's module).
_WORKER: dict = {}


def _init_worker(recording: Recording, strategy: str, out: Path, spec: dict) -> None:
    cv2.setNumThreads(1)
    if recording.consecutive is not None:
        recording.consecutive = tuple(
            np.load(path, mmap_mode="r+") for path in recording.consecutive
        )
    if isinstance(recording.mixed, str):
        recording.mixed = FlowDatabase(recording.mixed)
    recording.estimate = get_estimator(spec["estimator"], **spec["settings"])
    if spec.get("region") is not None:
        recording.estimate = in_region(recording.estimate, spec["region"])
    _WORKER.update(recording=recording, strategy=get_strategy(strategy), out=out, spec=spec)


def _consecutive_job(steps: list[int]) -> None:
    """Consecutive flows k -> k+1 (forward) and k+1 -> k (backward) for k in ``steps``."""
    recording: Recording = _WORKER["recording"]
    forward, backward = recording.consecutive
    for k in steps:
        slot = recording.slots[k]
        forward[slot] = recording.estimate(recording.frame(k), recording.frame(k + 1))
        backward[slot] = recording.estimate(recording.frame(k + 1), recording.frame(k))
    forward.flush()
    backward.flush()


def _pair_job(pair: Pair) -> dict:
    flows = _WORKER["strategy"].pair_flows(pair, _WORKER["recording"])
    spec = _WORKER["spec"]
    write_flow_pair(
        pair_path(_WORKER["out"], pair.source, pair.target),
        flows.forward,
        flows.backward,
        source=pair.source,
        target=pair.target,
        estimator=spec["estimator"],
        settings={
            **spec["settings"],
            "strategy": _WORKER["strategy"].name,
            **({"region": list(spec["region"])} if spec["region"] is not None else {}),
        },
    )
    log.info("flows %s <-> %s written", pair.source, pair.target)
    return {"source": pair.source, "target": pair.target, **flows.info}


def _no_estimator(image_a: np.ndarray, image_b: np.ndarray) -> np.ndarray:
    raise RuntimeError("the estimator is made in each worker")


def build_flow_database(
    out_dir: str | os.PathLike[str],
    *,
    visemes: pd.DataFrame,
    images_dir: str | os.PathLike[str],
    frames_dir: str | os.PathLike[str],
    estimator: str,
    settings: dict,
    strategy: str,
    window: int = 6,
    mask: np.ndarray | None = None,
    rest_viseme: str = "#",
    mixed: str | os.PathLike[str] | None = None,
    region: tuple[int, int, int, int] | None = None,
    workers: int = 1,
) -> pd.DataFrame:
    """Compute and write the flow database of ``visemes`` by ``strategy``.

    Parameters
    ----------
    out_dir : path
        Directory for the pair files (created).
    visemes : DataFrame
        The ``visemes.tsv`` table: columns ``viseme``, ``frame``, ``image``.
    images_dir : path
        Where the viseme images are.
    frames_dir : path
        The recording's frames (``concat``, ``mixed`` and ``bridge``).
    estimator, settings : str, dict
        Registry name and settings of the flow estimator.
    strategy : str
        A name in :data:`miketalk.flow.strategies.STRATEGIES`.
    window : int
        Frames before the end viseme's frame searched by ``mixed``.
    mask : (H, W) bool, optional
        Region for the mixed strategy's residual (the mouth); all pixels if None.
    rest_viseme : str
        The viseme of the rest pose (silence), whose look-alike frames ``bridge``
        passes through.
    mixed : path, optional
        For ``bridge``: the ``mixed`` database of the same estimator, settings
        and window (read instead of computed again).
    region : (x, y, w, h), optional
        Estimate flow inside this box only, zero outside
        (:func:`~miketalk.flow.registry.in_region`): for a stabilized recording
        whose only motion is the lower face. Default: the whole frame.
    workers : int
        Worker processes.

    Returns
    -------
    DataFrame
        One row per unordered pair with what the strategy chose (intermediate
        frames and chain lengths).
    """
    chosen = get_strategy(strategy)
    get_estimator(estimator, **settings)  # a bad name or setting fails here, not in a worker
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = list(visemes["viseme"])
    frame_of = dict(zip(visemes["viseme"], visemes["frame"].astype(int), strict=True))
    images = {
        v: read_image(Path(images_dir) / img)
        for v, img in zip(visemes["viseme"], visemes["image"], strict=True)
    }
    n_frames = count_frames(frames_dir)
    pairs = [
        Pair(a, b, images[a], images[b], frame_of[a], frame_of[b])
        for a, b in combinations(names, 2)
    ]
    rest = None
    if chosen.needs_rest:
        if rest_viseme not in frame_of:
            raise MiketalkError(f"the {strategy} strategy needs the rest viseme {rest_viseme!r}")
        rest = rest_frames(_FrameFiles(Path(frames_dir), n_frames), frame_of[rest_viseme])
    steps = chosen.steps(list(frame_of.values()), n_frames, rest)
    if rest is not None:
        log.info("%s: %d rest frames, %d consecutive flows", strategy, len(rest), len(steps))
    recording = Recording(
        estimate=_no_estimator,
        frames_dir=Path(frames_dir),
        n_frames=n_frames,
        window=window,
        mask=mask,
        rest=rest,
        mixed=None if mixed is None else str(mixed),
        viseme_frames=tuple(frame_of.values()),
        support=None if region is None else tuple(int(v) for v in region),
    )
    with tempfile.TemporaryDirectory(dir=out.parent, prefix=".consecutive-") as tmp:
        if steps:
            h, w = next(iter(images.values())).shape[:2]
            paths = tuple(str(Path(tmp) / f"{d}.npy") for d in ("forward", "backward"))
            for path in paths:
                np.lib.format.open_memmap(
                    path, mode="w+", dtype=np.float32, shape=(len(steps), h, w, 2)
                )
            recording.consecutive = paths
            recording.slots = {k: i for i, k in enumerate(steps)}
        # OpenCV's worker threads must not exist across the fork: a child inherits
        # their pool without the threads, and hangs on its first cv2.setNumThreads
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        try:
            with process_pool(
                workers,
                initializer=_init_worker,
                initargs=(
                    recording,
                    strategy,
                    out,
                    {"estimator": estimator, "settings": settings, "region": region},
                ),
            ) as pool:
                chunks = [steps[i : i + 25] for i in range(0, len(steps), 25)]
                list(map_in_pool(pool, _consecutive_job, chunks))
                rows = list(
                    map_in_pool(
                        pool, _pair_job, pairs, chunksize=_chunksize(chosen, pairs, workers)
                    )
                )
        finally:
            cv2.setNumThreads(threads)
    return pd.DataFrame(rows)


class _FrameFiles(Sequence):
    """The recording's frames, read one at a time: a long recording need not fit in memory."""

    def __init__(self, frames_dir: Path, n: int) -> None:
        self._dir, self._n = frames_dir, n

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, index):  # type: ignore[override]
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self._n))]
        index = int(index)
        if not -self._n <= index < self._n:
            raise IndexError(index)
        return read_image(frame_path(self._dir, index % self._n))


def _chunksize(strategy: Strategy, pairs: list[Pair], workers: int) -> int:
    """One pair at a time, or one contiguous block per worker (:attr:`Strategy.contiguous`)."""
    return max(1, -(-len(pairs) // workers)) if strategy.contiguous else 1
