"""The flows between visemes, by strategy: direct, concatenated, mixed or bridged (paper §5.2).

``direct``  the estimator between the two viseme images.
``concat``  concatenation (CONCATENATION-UP, Fig. 11) of the consecutive flows of
            the recording, from the first viseme's frame to the second's (run
            backwards in time when the second comes first).
``mixed``   the paper's mix: a direct flow from the start viseme to a frame that
            looks like it and lies shortly before the end viseme's frame, then
            concatenated flow from there (:func:`miketalk.flow.mixed_flow`).
``bridge``  ours: the mixed flow, or, where it explains the end image better (a
            smaller residual, the mixed strategy's own criterion), the bridge:
            concatenated flow from the first viseme's frame to the nearest rest
            frame, one direct flow to the rest frame nearest the second viseme,
            concatenated flow from there (:mod:`miketalk.flow.bridge`).

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
    FlowDatabase,
    concat_flows,
    concatenate_up_flows,
    get_estimator,
    mixed_flow,
    pair_path,
    window_chains,
    write_flow_pair,
)
from miketalk.flow.bridge import nearest_rest, rest_frames
from miketalk.flow.mixed import warp_residual
from miketalk.media.images import read_image

log = logging.getLogger(__name__)

STRATEGIES = ("direct", "concat", "mixed", "bridge")

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


def _consecutive_job(steps: list[int]) -> None:
    """Consecutive flows k -> k+1 (forward) and k+1 -> k (backward) for k in ``steps``."""
    estimate = _STATE["estimate"]
    forward, backward = _STATE["consecutive"]
    for k in steps:
        forward[k] = estimate(_frame(k), _frame(k + 1))
        backward[k] = estimate(_frame(k + 1), _frame(k))
    forward.flush()
    backward.flush()


def _chains_from(job: tuple[int, list[int]]) -> dict[int, np.ndarray]:
    """Concatenated flows along the recording from frame ``start`` to each frame of ``ends``.

    CONCATENATION-UP (Fig. 11) over the consecutive flows computed once for the
    whole recording, one pass forward in time for the later ends and one pass
    backward for the earlier ones. ``C_{s,k+1} = C_{s,k} + C_{k,k+1}(p + C_{s,k}(p))``
    is a left fold, so each end's flow is the fold's value when it reaches that
    frame: the same numbers as folding that end's chain alone, in one pass.
    """
    start, ends = job
    forward, backward = _STATE["consecutive"]
    out: dict[int, np.ndarray] = {}
    later = sorted(e for e in set(ends) if e > start)
    earlier = sorted((e for e in set(ends) if e < start), reverse=True)
    for targets, sign in ((later, 1), (earlier, -1)):
        total, k = None, start
        for end in targets:
            while k != end:
                step = np.asarray(forward[k] if sign > 0 else backward[k - 1])
                total = step.copy() if total is None else concat_flows(total, step)
                k += sign
            out[end] = total
    return out


def _pair_job(job: tuple) -> dict:
    strategy, a, b, image_a, image_b, frame_a, frame_b, window, mask = job
    estimate = _STATE["estimate"]
    info: dict = {"source": a, "target": b}
    if strategy == "direct":
        forward, backward = estimate(image_a, image_b), estimate(image_b, image_a)
    elif strategy == "bridge" and _STATE["mixed"] is not None:
        # the mixed database of the same method, made by its own job
        forward, backward = _STATE["mixed"].flow(a, b), _STATE["mixed"].flow(b, a)
        info.update(
            forward_residual=warp_residual(image_a, image_b, forward, mask),
            backward_residual=warp_residual(image_b, image_a, backward, mask),
        )
    else:
        forward, backward = _mixed_pair(info, image_a, image_b, frame_a, frame_b, window, mask)
    if strategy == "bridge":
        rest_a, rest_b = (nearest_rest(f, _STATE["rest"]) for f in (frame_a, frame_b))
        info.update(rest_a=rest_a, rest_b=rest_b)
        for direction, start, image_s, image_e, path in (
            ("forward", frame_a, image_a, image_b, (rest_a, rest_b, frame_b)),
            ("backward", frame_b, image_b, image_a, (rest_b, rest_a, frame_a)),
        ):
            # the bridge replaces the mixed flow where it explains the end image better
            flow = _bridge(start, *path)
            residual = warp_residual(image_s, image_e, flow, mask)
            use = residual < info[f"{direction}_residual"]
            info[f"{direction}_bridged"] = use
            if use:
                info[f"{direction}_residual"] = residual
                info[f"{direction}_chain"] = abs(start - path[0]) + abs(path[2] - path[1])
                forward, backward = (flow, backward) if direction == "forward" else (forward, flow)
    info["forward"], info["backward"] = forward, backward
    return _write_pair(info, *_STATE["write"])  # in the worker: writes run in parallel too


def _mixed_pair(info, image_a, image_b, frame_a, frame_b, window, mask):
    """The mixed strategy's flows both ways; what it chose goes into ``info``."""
    estimate, frames = _STATE["estimate"], _WindowFrames()
    forward, fwd = mixed_flow(
        image_a, frames, frame_b, estimate, window=window, mask=mask,
        chains=_chains_to(frame_b, window),
    )  # fmt: skip
    backward, bwd = mixed_flow(
        image_b, frames, frame_a, estimate, window=window, mask=mask,
        chains=_chains_to(frame_a, window),
    )  # fmt: skip
    info.update(
        forward_intermediate=fwd.index,
        forward_chain=frame_b - fwd.index,
        forward_residual=fwd.residuals[fwd.candidates.index(fwd.index)],
        backward_intermediate=bwd.index,
        backward_chain=frame_a - bwd.index,
        backward_residual=bwd.residuals[bwd.candidates.index(bwd.index)],
    )
    return forward, backward


def _steps(start: int, end: int) -> list[np.ndarray]:
    """The consecutive flows of the recording from frame ``start`` to frame ``end``."""
    forward, backward = _STATE["consecutive"]
    if end >= start:
        return [forward[k] for k in range(start, end)]
    return [backward[k - 1] for k in range(start, end, -1)]


def _bridge(start: int, rest_start: int, rest_end: int, end: int) -> np.ndarray:
    """``C_{start,end}`` through the rest frames (:mod:`miketalk.flow.bridge`)."""
    flows = _steps(start, rest_start)
    if rest_start != rest_end:
        flows.append(_STATE["estimate"](_frame(rest_start), _frame(rest_end)))
    flows += _steps(rest_end, end)
    if not flows:  # the same frame
        return np.zeros((*_frame(start).shape[:2], 2), np.float32)
    return concatenate_up_flows(flows)


def _chains_to(end: int, window: int) -> list[np.ndarray]:
    """:func:`window_chains` to frame ``end``, computed once per worker and end frame."""
    cache = _STATE.setdefault("chains", {})
    if end not in cache:
        cache[end] = window_chains(_WindowFrames(), end, _STATE["estimate"], window=window)
    return cache[end]


class _WindowFrames(Sequence):
    """The recording's frames, read lazily (mixed_flow touches only its window)."""

    def __len__(self) -> int:
        return _STATE["n_frames"]

    def __getitem__(self, index):  # type: ignore[override]
        return _frame(int(index))


def _init_worker(
    estimator: str,
    settings: dict,
    frames_dir: str,
    n_frames: int,
    consecutive: str | None,
    rest: np.ndarray | None,
    mixed: str | None,
    write: tuple,
) -> None:
    _init(estimator, settings, frames_dir)
    _STATE["write"] = write
    _STATE["n_frames"] = n_frames
    _STATE["rest"] = rest
    _STATE["mixed"] = FlowDatabase(mixed) if mixed is not None else None
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
    rest_viseme: str = "#",
    mixed: str | os.PathLike[str] | None = None,
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
    strategy : {"direct", "concat", "mixed", "bridge"}
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
    mixed = None if mixed is None else str(mixed)
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
    rest, steps = None, []
    if strategy == "concat":
        steps = list(range(n_frames - 1))
    elif strategy == "bridge":
        if rest_viseme not in frame_of:
            raise MiketalkError(f"the bridge strategy needs the rest viseme {rest_viseme!r}")
        recording = [read_image(p) for p in sorted(Path(frames_dir).glob("*.png"))]
        rest = rest_frames(recording, frame_of[rest_viseme])
        spans = [sorted((f, nearest_rest(f, rest))) for f in frame_of.values()]
        steps = sorted({k for lo, hi in spans for k in range(lo, hi)})
        log.info("bridge: %d rest frames, %d consecutive flows", len(rest), len(steps))
    with tempfile.TemporaryDirectory(dir=out.parent, prefix=".consecutive-") as tmp:
        consecutive = None
        if steps:
            consecutive = str(Path(tmp) / "flows")
            h, w = next(iter(images.values())).shape[:2]
            for d in ("forward", "backward"):
                np.lib.format.open_memmap(
                    f"{consecutive}.{d}.npy", mode="w+", dtype=np.float32,
                    shape=(max(n_frames - 1, 1), h, w, 2),
                )  # fmt: skip
        # OpenCV's worker threads must not exist across the fork: a child inherits
        # their pool without the threads, and hangs on its first cv2.setNumThreads
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        try:
            with ProcessPoolExecutor(
                max_workers=workers,
                initializer=_init_worker,
                initargs=(
                    estimator, settings, str(frames_dir), n_frames, consecutive, rest, mixed,
                    (out, estimator, settings, strategy),
                ),
            ) as pool:  # fmt: skip
                chunks = [steps[i : i + 25] for i in range(0, len(steps), 25)]
                list(pool.map(_consecutive_job, chunks))
                if strategy == "concat":
                    infos = _concat_infos(pool, jobs)
                    rows = [_write_pair(i, out, estimator, settings, strategy) for i in infos]
                else:
                    rows = list(pool.map(_pair_job, jobs, chunksize=1))
        finally:
            cv2.setNumThreads(threads)
    return pd.DataFrame(rows)


def _concat_infos(pool: ProcessPoolExecutor, jobs: list[tuple]) -> list[dict]:
    """The ``concat`` strategy's pair infos: one fold from each viseme frame to all others."""
    frames = sorted({job[5] for job in jobs} | {job[6] for job in jobs})
    starts = [(f, [g for g in frames if g != f]) for f in frames]
    chains = dict(zip(frames, pool.map(_chains_from, starts), strict=True))
    infos = []
    for _, a, b, image_a, _, frame_a, frame_b, *_ in jobs:
        if frame_a == frame_b:
            forward = backward = np.zeros((*image_a.shape[:2], 2), np.float32)
        else:
            forward, backward = chains[frame_a][frame_b], chains[frame_b][frame_a]
        infos.append(
            {"source": a, "target": b, "chain_length": abs(frame_b - frame_a),
             "forward": forward, "backward": backward}
        )  # fmt: skip
    return infos


def _write_pair(info: dict, out: Path, estimator: str, settings: dict, strategy: str) -> dict:
    """Write one pair's file; return its row (what the strategy chose, without the flows)."""
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
    log.info("flows %s <-> %s written", a, b)
    return {"source": a, "target": b, **info}
