"""Benchmark of the morph (paper §5.3-5.4) on one core, against cv2.remap and plain numpy.

``run(out_dir)`` times :class:`miketalk.render.morph.Morpher` frames (both forward
warps, hole-aware blend, scanline hole filling, 3x3 median) at 256x256 and
512x512 RGB, with the process pinned to one CPU and OpenCV limited to one
thread. In the same run it times ``cv2.remap`` (bilinear, one backward warp of
the same image: the speed ceiling) and :func:`numpy_morph`, a vectorised numpy
version of the same algorithm (the floor). Run it with
``python -m miketalk_lab.bench.morph --out DIR``.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import cv2
import numpy as np

from miketalk import defaults
from miketalk.media.atomic import write_text_atomic
from miketalk.render.morph import Morpher
from miketalk.render.splat import HOLE_VALUE

SIZES = (256, 512)
_MIN_SECONDS = 0.5  # time each case for at least this long
_REPEATS = 3  # best of


# ---------------------------------------------------------------------------
# the numpy reference
# ---------------------------------------------------------------------------


def _numpy_splat(flow: np.ndarray, scale: float, collision: str = "motion") -> np.ndarray:
    """Source index per destination pixel (-1 = hole), same rule as the C kernel."""
    h, w = flow.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w]
    qx = np.floor(xs + scale * flow[..., 0].astype(np.float64) + 0.5).ravel()
    qy = np.floor(ys + scale * flow[..., 1].astype(np.float64) + 0.5).ravel()
    inside = (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h)
    src = np.flatnonzero(inside)
    dest = (qy[inside] * w + qx[inside]).astype(np.int64)
    if collision == "motion":  # dx * dx + dy * dy in float32, as miketalk.render.morph computes it
        dx, dy = flow[..., 0], flow[..., 1]
        priority = (dx * dx + dy * dy).ravel()[src]
    else:
        priority = np.zeros(src.size, np.float32)
    order = np.lexsort((src, priority, dest))  # winner = last of each destination group
    dest, src = dest[order], src[order]
    last = np.append(dest[1:] != dest[:-1], True)
    index = np.full(h * w, -1, np.int64)
    index[dest[last]] = src[last]
    return index.reshape(h, w)


def _lerp_1d(values: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """Fill holes along axis 1 of (N, L, C) float ``values``; rows without data stay holes."""
    n, length = hole.shape
    positions = np.broadcast_to(np.arange(length), (n, length))
    left = np.maximum.accumulate(np.where(hole, -1, positions), axis=1)
    right = np.minimum.accumulate(np.where(hole, length, positions)[:, ::-1], axis=1)[:, ::-1]
    left = np.where(left < 0, right, left)
    right = np.where(right >= length, left, right)
    rows = np.arange(n)[:, None]
    ok = left < length  # False only on rows without any data
    left, right = np.where(ok, left, 0), np.where(ok, right, 0)
    span = right - left
    t = np.where(span != 0, (positions - left) / np.where(span != 0, span, 1), 0.0)[..., None]
    lo = values[rows, left]
    filled = np.floor(lo + t * (values[rows, right] - lo) + 0.5)
    return np.where((hole & ok)[..., None], filled, values)


def numpy_morph(
    image0: np.ndarray,
    image1: np.ndarray,
    flow01: np.ndarray,
    flow10: np.ndarray,
    alpha: float,
    *,
    collision: str = "motion",
) -> np.ndarray:
    """The full morph in vectorised numpy (no compiled kernel): the reference and the speed floor.

    Same algorithm, rounding and collision rule as :func:`miketalk.render.morph.morph`
    with every stage on, so the two agree bit for bit. No input checks.
    """
    shape = image0.shape
    h, w = shape[:2]
    pixels0 = image0.reshape(h * w, -1).astype(np.float64)
    pixels1 = image1.reshape(h * w, -1).astype(np.float64)
    index0 = _numpy_splat(flow01, alpha, collision).ravel()
    index1 = _numpy_splat(flow10, 1.0 - alpha, collision).ravel()
    has0, has1 = (index0 >= 0)[:, None], (index1 >= 0)[:, None]
    warp0, warp1 = pixels0[np.maximum(index0, 0)], pixels1[np.maximum(index1, 0)]
    both = np.floor((1.0 - alpha) * warp0 + alpha * warp1 + 0.5)
    blend = np.where(has0 & has1, both, np.where(has0, warp0, np.where(has1, warp1, HOLE_VALUE)))
    hole = ~(has0 | has1)[:, 0].reshape(h, w)
    out = _lerp_1d(blend.reshape(h, w, -1), hole)
    empty = hole.all(axis=1)
    out = _lerp_1d(out.transpose(1, 0, 2), np.broadcast_to(empty, (w, h))).transpose(1, 0, 2)
    out = np.ascontiguousarray(out.astype(np.uint8))
    final = cv2.medianBlur(out[..., 0] if out.shape[2] == 1 else out, 3)
    return final.reshape(shape)


# ---------------------------------------------------------------------------
# the scene and the timing
# ---------------------------------------------------------------------------


def scene(size: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A textured RGB pair and its flows: a disc that grows by ``size / 16`` pixels of radius.

    The flows are divergent (the disc expands over the background), so the
    forward warps leave holes and have collisions, as a mouth opening does.
    """
    rng = np.random.default_rng(seed)
    noise = rng.random((size // 8, size // 8, 3)).astype(np.float32)
    texture = cv2.resize(noise, (size, size), interpolation=cv2.INTER_CUBIC)
    ys, xs = np.mgrid[0:size, 0:size].astype(np.float32)
    c = (size - 1) / 2
    rx, ry = xs - c, ys - c
    r = np.hypot(rx, ry) + 1e-6
    r0, grow = size / 4, size / 16
    # radial displacement: grows linearly inside the disc, decays to 0 outside
    gain = np.where(r < r0, grow / r0, grow / r * np.exp(-(r - r0) / (size / 16)))
    flow01 = np.stack([rx * gain, ry * gain], axis=-1).astype(np.float32)
    flow10 = -flow01  # good enough for timing
    image0 = np.clip(255 * texture, 0, 255).astype(np.uint8)
    image1 = np.clip(255 * texture[::-1], 0, 255).astype(np.uint8)
    return image0, image1, flow01, flow10


def _fps(render: Callable[[float], object], frames: int = 32) -> float:
    """Best-of frames per second of ``render(alpha)`` over an alpha sweep."""
    alphas = np.linspace(0.0, 1.0, frames)
    render(0.5)  # warm (caches)
    best = 0.0
    for _ in range(_REPEATS):
        count, start = 0, time.perf_counter()
        while (elapsed := time.perf_counter() - start) < _MIN_SECONDS or count == 0:
            for alpha in alphas:
                render(float(alpha))
            count += frames
        best = max(best, count / elapsed)
    return best


@contextmanager
def one_core() -> Iterator[None]:
    """Pin the process to one CPU and OpenCV to one thread; restore afterwards."""
    affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    cv_threads = cv2.getNumThreads()
    try:
        if affinity:
            os.sched_setaffinity(0, {min(affinity)})
        cv2.setNumThreads(1)
        yield
    finally:
        if affinity:
            os.sched_setaffinity(0, affinity)
        cv2.setNumThreads(cv_threads)


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """Time the morph at 256² and 512² RGB on one core; print a table; write ``morph.json``.

    Parameters
    ----------
    out_dir : pathlib.Path
        Where ``morph.json`` (the returned figures) is written.

    Returns
    -------
    dict of str to float
        ``morph_fps_256``, ``remap_fps_256``, ``numpy_fps_256`` and the same for
        512: frames per second, best of three runs.
    """
    figures: dict[str, float] = {}
    with one_core():
        for size in SIZES:
            image0, image1, flow01, flow10 = scene(size)
            morpher = Morpher(image0, image1, flow01, flow10)
            grid = np.dstack(np.meshgrid(np.arange(size), np.arange(size))).astype(np.float32)
            remap_map = grid + flow01
            figures[f"morph_fps_{size}"] = _fps(morpher.frame)
            figures[f"remap_fps_{size}"] = _fps(
                lambda _a, m=remap_map, im=image0: cv2.remap(
                    im, m, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
                )
            )
            figures[f"numpy_fps_{size}"] = _fps(
                lambda a, s=(image0, image1, flow01, flow10): numpy_morph(*s, a), frames=8
            )
    _print_table(figures)
    out_dir = pathlib.Path(out_dir)
    write_text_atomic(out_dir / "morph.json", json.dumps(figures, indent=2, sort_keys=True) + "\n")
    return figures


def _print_table(figures: dict[str, float]) -> None:
    print("morph, one core, RGB, frames/s (best of 3)")
    print(f"{'size':>6} {'morph':>9} {'cv2.remap':>10} {'numpy':>8} {'morph/remap':>12}")
    for size in SIZES:
        m, r, n = (figures[f"{k}_fps_{size}"] for k in ("morph", "remap", "numpy"))
        print(f"{size:>4}² {m:>9.0f} {r:>10.0f} {n:>8.1f} {m / r:>12.2f}")


def main() -> None:
    """``python -m miketalk_lab.bench.morph --out DIR``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=defaults.RESULTS / "bench")
    run(parser.parse_args().out)


if __name__ == "__main__":
    main()
