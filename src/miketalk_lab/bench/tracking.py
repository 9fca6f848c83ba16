"""Benchmark of face tracking on hard s1: the error against a known motion, speed and memory.

``python -m miketalk_lab.bench.tracking --clips data/grid_s1/video --out results/bench/tracking
[--limit N] [--hd N] [--seed S] [--look DIR] [--rgb]``

For each GRID clip (``*.mpg`` of ``--clips``, in name order) it writes the clip's hard
version (:mod:`miketalk_lab.hard_s1`: a textured room, a known smooth similarity
motion, 1280x720) to a scratch folder, tracks the plain clip (360x288) and the hard one
(:func:`miketalk.track.track_frames`, both streamed from their files in grey as ``miketalk
build`` tracks any video, :func:`miketalk.track.video_crops.crop_video`; ``--rgb``: in RGB,
as the build did before),
and measures, on the frames tracked in both, the **tracking error**: the five canonical
face points reprojected into the hard frame through the hard clip's track, against the
same points reprojected into the plain frame through the plain clip's track and mapped
by the known motion (the truth), RMS over the points, in pixels of the hard frame. Both
tracks are the smoothed ones; ``raw`` is the same before smoothing.

The first ``--hd`` clips are also made at 1920x1080 (the clip scaled by 3), tracked, and
measured the same way (their error also in 720p pixels: divided by 1.5).

Speed: the tracker's CPU time per frame (``time.process_time``, the decoding excluded:
ffmpeg runs in its own process) and its wall time. Memory: the peak resident size of a
fresh process that tracks one hard clip streamed from its file, at each resolution, and
of one that only loads the models (``VmHWM``; ``resource.getrusage``'s ``ru_maxrss`` where
there is no ``/proc``: on Linux it starts from the parent's, so it is not used there).

Writes ``OUT/tracking.csv`` (one row per clip and resolution) and ``OUT/summary.md``
(the tables), prints the summary; ``--look DIR`` also writes strips (plain | hard | the
canonical crops of both) of the first clips as PNGs.
"""

from __future__ import annotations

import csv
import io
import multiprocessing
import resource
import sys
import tempfile
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.media.decode import iter_video_frames, read_video, video_info
from miketalk.media.images import write_png
from miketalk.track import (
    CANONICAL_LANDMARKS,
    FaceCropSettings,
    FaceTracker,
    Track,
    TrackerSettings,
    apply_affine,
    face_crop,
    invert_affine,
)
from miketalk.track.detect import load_models
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.hard_s1 import make_hard_clip

TARGET_RMS_PX = 1.0  # at 720p, the target
_COLUMNS = (
    "clip", "size", "frames", "tracked_plain", "tracked_hard", "compared", "rms_px", "p95_px",
    "max_px", "rms_raw_px", "rms_720p_px", "cpu_ms_per_frame", "wall_ms_per_frame", "failures",
)  # fmt: skip
_SIZES = {720: (1280, 720), 1080: (1920, 1080)}


@dataclass(frozen=True)
class _Timed:
    track: Track
    cpu_s: float
    wall_s: float


def _track_timed(frames: Iterable[np.ndarray], fps: float, settings: TrackerSettings) -> _Timed:
    """Track frames, timing the tracker alone (not the frames' decoding)."""
    load_models()
    tracker = FaceTracker(fps=fps, settings=settings)
    cpu = wall = 0.0
    for frame in frames:
        c0, w0 = time.process_time(), time.perf_counter()
        tracker.update(frame)
        cpu += time.process_time() - c0
        wall += time.perf_counter() - w0
    c0, w0 = time.process_time(), time.perf_counter()
    track = tracker.finish()
    return _Timed(track, cpu + time.process_time() - c0, wall + time.perf_counter() - w0)


def reprojection_errors(hard: np.ndarray, plain: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Per frame, the RMS distance in hard-frame pixels between the canonical face points
    reprojected by the hard track and the plain track's mapped by the truth.

    Parameters
    ----------
    hard, plain : numpy.ndarray
        ``(N, 2, 3)`` frame-to-canonical transforms of the two clips (NaN: not tracked).
    truth : numpy.ndarray
        ``(N, 2, 3)`` the known maps from plain-frame to hard-frame pixels.

    Returns
    -------
    numpy.ndarray
        ``(N,)``, NaN where either clip's frame is not tracked.
    """
    out = np.full(len(truth), np.nan)
    for k in range(len(truth)):
        if not (np.isfinite(hard[k]).all() and np.isfinite(plain[k]).all()):
            continue
        estimate = apply_affine(invert_affine(hard[k]), CANONICAL_LANDMARKS)
        expected = apply_affine(
            truth[k], apply_affine(invert_affine(plain[k]), CANONICAL_LANDMARKS)
        )
        out[k] = float(np.sqrt(((estimate - expected) ** 2).sum(axis=1).mean()))
    return out


def _rms(values: np.ndarray) -> float:
    v = values[np.isfinite(values)]
    return float(np.sqrt((v**2).mean())) if v.size else float("nan")


def _failures(track: Track, label: str) -> str:
    return "; ".join(f"{label} {f}" for f in track.failures())


def _peak_mb() -> float:
    """This process's peak resident size in MB: ``VmHWM`` of ``/proc/self/status`` (Linux),
    else ``resource.getrusage``'s ``ru_maxrss`` (which Linux carries over from the parent
    across fork and exec, so it can show the parent's peak)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _memory_child(path: str, queue: multiprocessing.Queue) -> None:  # pragma: no cover
    """In a fresh process: the peak resident size (MB) after loading the models, and after
    tracking the video at ``path`` streamed (empty path: models only)."""
    load_models()
    loaded = _peak_mb()
    if path:
        from miketalk.media.decode import video_info

        _, _, fps = video_info(path)
        tracker = FaceTracker(fps=fps)
        for frame in iter_video_frames(path, grey=True):
            tracker.update(frame)
        tracker.finish()
    queue.put((loaded, _peak_mb()))


def peak_memory_mb(path: Path | None) -> tuple[float, float]:
    """Peak resident size (MB) of a fresh process after loading the models and at the end of
    tracking ``path`` (None: loading only)."""
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_memory_child, args=(str(path or ""), queue))
    child.start()
    result = queue.get(timeout=1800)
    child.join()
    return result


def look_strip(
    plain: np.ndarray | Mapping[int, np.ndarray],
    hard: np.ndarray | Mapping[int, np.ndarray],
    plain_track: Track,
    hard_track: Track,
    indices: Sequence[int],
    *,
    height: int = 256,
) -> np.ndarray:
    """Rows of ``plain | hard | plain's crop | hard's crop`` for a few frames, ``height`` high.

    ``plain`` and ``hard`` are the frames (arrays, or frame index to frame, indexed like the
    tracks); a frame left out shows its crop as grey. The frame's five landmarks are dotted
    on its crop.
    """
    settings = FaceCropSettings(size=height)
    rows = []
    for k in indices:
        cells = []
        for frames in (plain, hard):
            f = frames[k]
            w = round(f.shape[1] * height / f.shape[0])
            cells.append(cv2.resize(f, (w, height), interpolation=cv2.INTER_AREA))
        for frames, track in ((plain, plain_track), (hard, hard_track)):
            t = track.transform(k)
            crop = np.full((height, height, 3), 128, np.uint8)
            if t is not None:
                crop = face_crop(frames[k], t, settings)
                for x, y in apply_affine(settings.transform(t), track.landmarks[k]):
                    cv2.circle(crop, (round(x), round(y)), 3, (255, 255, 0), -1)
            cells.append(crop)
        row = np.concatenate(cells, axis=1)
        rows.append(row)
    return np.concatenate(rows, axis=0)


def run(
    clips: Path,
    out: Path,
    *,
    limit: int | None = None,
    hd: int = 3,
    seed: int = 0,
    look: Path | None = None,
    settings: TrackerSettings | None = None,
    rgb: bool = False,
) -> str:
    """Make, track and measure hard s1; write the CSV and the summary; return the summary.

    Parameters
    ----------
    clips : pathlib.Path
        A folder of GRID clips (``*.mpg``).
    out : pathlib.Path
        Folder for ``tracking.csv`` and ``summary.md`` (created).
    limit : int, optional
        Only the first ``limit`` clips.
    hd : int
        How many of them also at 1080p.
    seed : int
        Hard s1's seed.
    look : pathlib.Path, optional
        Folder for strips of the first two clips.
    settings : TrackerSettings, optional
        The tracker's settings.
    rgb : bool
        Track RGB frames (else grey ones, as the build does).

    Returns
    -------
    str
        The markdown summary.
    """
    settings = settings or TrackerSettings()
    paths = sorted(clips.glob("*.mpg"))[:limit]
    if not paths:
        raise MiketalkError(f"no GRID clips (*.mpg) in {clips}")
    rows: list[dict[str, object]] = []
    errors: dict[int, list[np.ndarray]] = {720: [], 1080: []}
    raw_errors: dict[int, list[np.ndarray]] = {720: [], 1080: []}
    times: dict[int | str, list[float]] = {720: [0.0, 0.0, 0], 1080: [0.0, 0.0, 0],
                                           "plain": [0.0, 0.0, 0]}  # fmt: skip
    memory_files: dict[int, Path] = {}
    with tempfile.TemporaryDirectory(prefix="hard_s1_") as scratch:
        for index, path in enumerate(paths):
            _, _, fps = video_info(path)
            plain_timed = _track_timed(iter_video_frames(path, grey=not rgb), fps, settings)
            plain_track = plain_timed.track
            times["plain"][0] += plain_timed.cpu_s
            times["plain"][1] += plain_timed.wall_s
            times["plain"][2] += len(plain_track)
            for height in (720, 1080) if index < hd else (720,):
                video = Path(scratch) / f"{path.stem}_{height}.mp4"
                hard = make_hard_clip(path, video, size=_SIZES[height], seed=seed)
                timed = _track_timed(iter_video_frames(video, grey=not rgb), fps, settings)
                times[height][0] += timed.cpu_s
                times[height][1] += timed.wall_s
                times[height][2] += len(timed.track)
                err = reprojection_errors(timed.track.transforms, plain_track.transforms,
                                          hard.truth)  # fmt: skip
                raw = reprojection_errors(timed.track.raw, plain_track.raw, hard.truth)
                errors[height].append(err)
                raw_errors[height].append(raw)
                if index == 0:  # kept for the memory runs
                    memory_files[height] = Path(scratch) / f"memory_{height}.mp4"
                    video.replace(memory_files[height])
                    video = memory_files[height]
                rows.append(
                    {
                        "clip": path.stem, "size": f"{_SIZES[height][0]}x{height}",
                        "frames": len(timed.track),
                        "tracked_plain": int(plain_track.tracked.sum()),
                        "tracked_hard": int(timed.track.tracked.sum()),
                        "compared": int(np.isfinite(err).sum()),
                        "rms_px": _rms(err),
                        "p95_px": float(np.nanpercentile(err, 95)) if np.isfinite(err).any()
                        else float("nan"),
                        "max_px": float(np.nanmax(err)) if np.isfinite(err).any()
                        else float("nan"),
                        "rms_raw_px": _rms(raw), "rms_720p_px": _rms(err) * 720 / height,
                        "cpu_ms_per_frame": 1000 * timed.cpu_s / len(timed.track),
                        "wall_ms_per_frame": 1000 * timed.wall_s / len(timed.track),
                        "failures": "; ".join(
                            f for f in (_failures(plain_track, "plain"),
                                        _failures(timed.track, "hard")) if f
                        ),
                    }
                )  # fmt: skip
                print(
                    f"{path.stem} {height}p: RMS {_rms(err):.3f} px (raw {_rms(raw):.3f}), "
                    f"tracked {int(plain_track.tracked.sum())}/{int(timed.track.tracked.sum())}"
                    f" of {len(plain_track)}, {1000 * timed.cpu_s / len(timed.track):.1f} ms/frame"
                    " CPU",
                    flush=True,
                )
                if look is not None and index < 2 and height == 720:
                    plain, _ = read_video(path)
                    picks = np.linspace(0, len(plain) - 1, 4).round().astype(int)
                    wanted = {
                        int(k): f for k, f in enumerate(iter_video_frames(video)) if k in picks
                    }
                    strip = look_strip(plain, wanted, plain_track, timed.track, picks)
                    write_png(look / f"hard_s1_{path.stem}.png", strip)
        memory = {"models only": peak_memory_mb(None)}
        for height, video in sorted(memory_files.items()):
            memory[f"{_SIZES[height][0]}x{height}"] = peak_memory_mb(video)

    out.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(_COLUMNS)
    for row in rows:
        writer.writerow(
            [f"{v:.4f}" if isinstance(v, float) else v for v in (row[c] for c in _COLUMNS)]
        )
    write_text_atomic(out / "tracking.csv", buffer.getvalue())
    summary = _summary(clips, paths, rows, errors, raw_errors, times, memory)
    write_text_atomic(out / "summary.md", summary)
    return summary


def _summary(
    clips: Path,
    paths: list[Path],
    rows: list[dict[str, object]],
    errors: dict[int, list[np.ndarray]],
    raw_errors: dict[int, list[np.ndarray]],
    times: dict[int | str, list[float]],
    memory: dict[str, tuple[float, float]],
) -> str:
    """The markdown summary of :func:`run`."""
    lines = [
        f"# Face tracking on hard s1: {len(paths)} clips of {clips}",
        "",
        "Tracking error: the canonical face points through the hard clip's track against "
        "the plain clip's mapped by the known motion (RMS over points and frames, pixels of "
        "the hard frame; raw: before smoothing).",
        "",
        "| size | clips | frames | compared | RMS px | p95 px | max px | RMS raw px | "
        "RMS in 720p px |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for height in (720, 1080):
        if not errors[height]:
            continue
        err = np.concatenate(errors[height])
        raw = np.concatenate(raw_errors[height])
        finite = err[np.isfinite(err)]
        lines.append(
            f"| {_SIZES[height][0]}x{height} | {len(errors[height])} | {len(err)} | "
            f"{finite.size} | {_rms(err):.3f} | {np.percentile(finite, 95):.3f} | "
            f"{finite.max():.3f} | {_rms(raw):.3f} | {_rms(err) * 720 / height:.3f} |"
        )
    overall = _rms(np.concatenate(errors[720]))
    lines += [
        "",
        f"Target (720p, RMS <= {TARGET_RMS_PX} px): "
        f"{'met' if overall <= TARGET_RMS_PX else 'NOT met'} ({overall:.3f} px).",
        "",
        "Tracker time per frame (the decoding excluded; CPU: process time):",
        "",
        "| frames | count | CPU ms/frame | wall ms/frame |",
        "| --- | --- | --- | --- |",
    ]
    for key, label in (("plain", "360x288 (plain)"), (720, "1280x720"), (1080, "1920x1080")):
        cpu, wall, n = times[key]
        if n:
            lines.append(f"| {label} | {n} | {1000 * cpu / n:.2f} | {1000 * wall / n:.2f} |")
    lines += [
        "",
        "Peak resident memory of a fresh process (MB):",
        "",
        "| process | models loaded | end of tracking one clip |",
        "| --- | --- | --- |",
    ]
    for label, (loaded, peak) in memory.items():
        lines.append(f"| {label} | {loaded:.0f} | {peak:.0f} |")
    worst = sorted((r for r in rows if r["size"] == "1280x720"), key=lambda r: -r["rms_px"])[:8]
    lines += ["", "Worst clips at 720p:", "", "| clip | RMS px | p95 px | max px | compared "
              "| failures |", "| --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for r in worst:
        lines.append(
            f"| {r['clip']} | {r['rms_px']:.3f} | {r['p95_px']:.3f} | {r['max_px']:.3f} | "
            f"{r['compared']}/{r['frames']} | {r['failures'] or '-'} |"
        )
    failed = [r for r in rows if r["failures"]]
    lines += ["", f"Clips with frames left out: {len(failed)} of {len(rows)} runs."]
    lines += [f"- {r['clip']} {r['size']}: {r['failures']}" for r in failed]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Make hard s1, track it and measure the error, speed and memory.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (``sys.argv[1:]`` by default).

    Returns
    -------
    int
        0 on success, 1 on a MiketalkError (printed on stderr).
    """
    parser = bench_parser(__name__, __doc__, limit_help="the first N clips only")
    parser.add_argument("--clips", type=Path, required=True, help="a folder of GRID *.mpg clips")
    parser.add_argument(
        "--out", type=Path, default=defaults.RESULTS / "bench" / "tracking", help="output folder"
    )
    parser.add_argument("--hd", type=int, default=3, help="clips also made at 1080p (default 3)")
    parser.add_argument("--seed", type=int, default=0, help="hard s1's seed (default 0)")
    parser.add_argument("--look", type=Path, default=None, help="folder for strip PNGs")
    parser.add_argument("--rgb", action="store_true", help="track RGB frames (not grey)")
    return run_bench(
        parser,
        argv,
        lambda a: run(a.clips, a.out, limit=a.limit, hd=a.hd, seed=a.seed, look=a.look, rgb=a.rgb),
        check=lambda a: "--hd must be at least 0" if a.hd < 0 else None,
    )


if __name__ == "__main__":
    sys.exit(main())
