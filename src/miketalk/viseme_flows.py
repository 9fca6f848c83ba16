"""The flows between visemes, by strategy: direct, concatenated, or mixed (paper §5.2).

``direct``  the estimator between the two viseme images.
``concat``  concatenation (CONCATENATION-UP, Fig. 11) of the consecutive flows of
            the recording, from the first viseme's frame to the second's (run
            backwards in time when the second comes first).
``mixed``   the paper's mix: a direct flow from the start viseme to a frame that
            looks like it and lies shortly before the end viseme's frame, then
            concatenated flow from there (:func:`miketalk.flow.mixed_flow`).

Each unordered pair is one OpenEXR file (forward and backward layers). Pairs are
independent jobs, spread over worker processes; results do not depend on the
number of workers.
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from itertools import combinations
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.flow import (
    concatenate_up_flows,
    get_estimator,
    mixed_flow,
    pair_path,
    write_flow_pair,
)
from miketalk.images import read_image

log = logging.getLogger(__name__)

STRATEGIES = ("direct", "concat", "mixed")

# worker-process state, set by _init
_STATE: dict = {}


def _init(estimator: str, settings: dict, frames_dir: str | None) -> None:
    cv2.setNumThreads(1)
    _STATE["estimate"] = get_estimator(estimator, **settings)
    _STATE["frames_dir"] = frames_dir
    _STATE["frames"] = {}


def _frame(index: int) -> np.ndarray:
    cache = _STATE["frames"]
    if index not in cache:
        cache[index] = read_image(Path(_STATE["frames_dir"]) / f"{index:06d}.png")
    return cache[index]


def _consecutive_job(job: tuple[int, int]) -> None:
    """Consecutive flows k -> k+1 (forward) and k+1 -> k (backward) for k in [lo, hi)."""
    lo, hi = job
    estimate = _STATE["estimate"]
    forward, backward = _STATE["consecutive"]
    for k in range(lo, hi):
        forward[k] = estimate(_frame(k), _frame(k + 1))
        backward[k] = estimate(_frame(k + 1), _frame(k))
    forward.flush()
    backward.flush()


def _chain(start: int, end: int) -> np.ndarray:
    """Concatenated flow along the recording from frame ``start`` to frame ``end``.

    Uses the consecutive flows computed once for the whole recording
    (CONCATENATION-UP over ``|end - start|`` flows).
    """
    forward, backward = _STATE["consecutive"]
    if end > start:
        flows = [forward[k] for k in range(start, end)]
    else:
        flows = [backward[k - 1] for k in range(start, end, -1)]
    return concatenate_up_flows(flows)


def _pair_job(job: tuple) -> dict:
    strategy, a, b, image_a, image_b, frame_a, frame_b, window, mask = job
    estimate = _STATE["estimate"]
    info: dict = {"source": a, "target": b}
    if strategy == "direct":
        forward, backward = estimate(image_a, image_b), estimate(image_b, image_a)
    elif strategy == "concat":
        if frame_a == frame_b:
            forward = backward = np.zeros((*image_a.shape[:2], 2), np.float32)
        else:
            forward, backward = _chain(frame_a, frame_b), _chain(frame_b, frame_a)
        info["chain_length"] = abs(frame_b - frame_a)
    else:
        frames = _WindowFrames()
        forward, fwd = mixed_flow(image_a, frames, frame_b, estimate, window=window, mask=mask)
        backward, bwd = mixed_flow(image_b, frames, frame_a, estimate, window=window, mask=mask)
        info.update(
            forward_intermediate=fwd.index,
            forward_chain=frame_b - fwd.index,
            forward_residual=fwd.residuals[fwd.candidates.index(fwd.index)],
            backward_intermediate=bwd.index,
            backward_chain=frame_a - bwd.index,
            backward_residual=bwd.residuals[bwd.candidates.index(bwd.index)],
        )
    info["forward"], info["backward"] = forward, backward
    return info


class _WindowFrames(Sequence):
    """The recording's frames, read lazily (mixed_flow touches only its window)."""

    def __len__(self) -> int:
        return _STATE["n_frames"]

    def __getitem__(self, index):  # type: ignore[override]
        return _frame(int(index))


def _init_worker(
    estimator: str, settings: dict, frames_dir: str, n_frames: int, consecutive: str | None
) -> None:
    _init(estimator, settings, frames_dir)
    _STATE["n_frames"] = n_frames
    if consecutive is not None:
        h, w = _frame(0).shape[:2]
        shape = (max(n_frames - 1, 1), h, w, 2)
        _STATE["consecutive"] = tuple(
            np.lib.format.open_memmap(
                f"{consecutive}.{d}.npy", mode="r+", dtype=np.float32, shape=shape
            )
            for d in ("forward", "backward")
        )


def build_flow_database(
    out_dir: str | os.PathLike[str],
    *,
    visemes: pd.DataFrame,
    images_dir: str | os.PathLike[str],
    frames_dir: str | os.PathLike[str],
    estimator: str,
    settings: dict,
    strategy: str,
    window: int = 12,
    mask: np.ndarray | None = None,
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
        The recording's frames (``concat`` and ``mixed``).
    estimator, settings : str, dict
        Registry name and settings of the flow estimator.
    strategy : {"direct", "concat", "mixed"}
    window : int
        Frames before the end viseme's frame searched by ``mixed``.
    mask : (H, W) bool, optional
        Region for the mixed strategy's residual (the mouth); all pixels if None.
    workers : int
        Worker processes.

    Returns
    -------
    DataFrame
        One row per unordered pair with what the strategy chose (intermediate
        frames and chain lengths).
    """
    if strategy not in STRATEGIES:
        raise MiketalkError(f"unknown flow strategy {strategy!r}; use one of {STRATEGIES}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = list(visemes["viseme"])
    frame_of = dict(zip(visemes["viseme"], visemes["frame"].astype(int), strict=True))
    images = {
        v: read_image(Path(images_dir) / img)
        for v, img in zip(visemes["viseme"], visemes["image"], strict=True)
    }
    n_frames = len(list(Path(frames_dir).glob("*.png")))
    jobs = [
        (strategy, a, b, images[a], images[b], frame_of[a], frame_of[b], window, mask)
        for a, b in combinations(names, 2)
    ]
    rows = []
    with tempfile.TemporaryDirectory(dir=out.parent, prefix=".consecutive-") as tmp:
        consecutive = None
        if strategy == "concat":
            consecutive = str(Path(tmp) / "flows")
            h, w = next(iter(images.values())).shape[:2]
            for d in ("forward", "backward"):
                np.lib.format.open_memmap(
                    f"{consecutive}.{d}.npy", mode="w+", dtype=np.float32,
                    shape=(max(n_frames - 1, 1), h, w, 2),
                )  # fmt: skip
        with ProcessPoolExecutor(
            max_workers=workers,
            initializer=_init_worker,
            initargs=(estimator, settings, str(frames_dir), n_frames, consecutive),
        ) as pool:
            if consecutive is not None:
                step = 25
                chunks = [(lo, min(lo + step, n_frames - 1)) for lo in range(0, n_frames - 1, step)]
                list(pool.map(_consecutive_job, chunks))
            rows = _write_pairs(pool, jobs, out, estimator, settings, strategy)
    return pd.DataFrame(rows)


def _write_pairs(pool, jobs, out, estimator, settings, strategy) -> list[dict]:
    rows = []
    for info in pool.map(_pair_job, jobs, chunksize=1):
        a, b = info.pop("source"), info.pop("target")
        write_flow_pair(
            pair_path(out, a, b),
            info.pop("forward"),
            info.pop("backward"),
            source=a,
            target=b,
            estimator=estimator,
            settings={**settings, "strategy": strategy},
        )
        rows.append({"source": a, "target": b, **info})
        log.info("flows %s <-> %s written", a, b)
    return rows
