"""Benchmark of talking-head stabilization on real clips: residual motion before and after.

``python -m miketalk_lab.bench.stabilization --pool DIR --out OUT [--limit N]`` takes
the clips of a pool (``DIR/video/*.mpg``, GRID's layout, or the video files in
``DIR`` itself) in name order, picks the reference frame in the first clip
(:func:`~miketalk.stabilize.choose_reference`), builds a
:class:`~miketalk.stabilize.Stabilizer` from it (the mouth found in the
first clip), and registers every frame of every clip to that one frame.

For each frame it measures the residual motion
(:func:`~miketalk.stabilize.residual_motion`: mean DIS-flow magnitude
from the reference) on two masks of the reference:

- the **target** mask, ``registration_mask(region="rigid")``: the face between
  the eyes and the mouth zone (nose, cheeks), without the eyes (blinks),
  the forehead (hair) and the jaw (it moves with speech);
- the **face** mask, ``registration_mask(region="face")``: the whole face
  outside the mouth zone, forehead, eyes and jaw included.

on the frames as decoded (``before``), after the affine registration alone
(``after_affine``) and after the clip's conform field too (``after``).

Writes ``OUT/stabilization.csv`` (one row per frame: clip, frame, before_px,
after_px, after_affine_px, before_face_px, after_face_px, correlation,
registered) and ``OUT/summary.md`` (median, 95th percentile and largest of
each, frames that did not register, milliseconds per frame of each step), and
prints the summary.
"""

from __future__ import annotations

import csv
import io
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.media.decode import read_video
from miketalk.stabilize import Stabilizer, choose_reference, registration_mask, residual_motion
from miketalk_lab.bench.command import bench_parser, run_bench

_VIDEO_SUFFIXES = (".mpg", ".mpeg", ".mp4", ".avi", ".mov", ".mkv")
_COLUMNS = (
    "clip",
    "frame",
    "before_px",
    "after_px",
    "after_affine_px",
    "before_face_px",
    "after_face_px",
    "correlation",
    "registered",
)
TARGET_MEDIAN_PX, TARGET_P95_PX = 0.3, 1.0  # the target, on the target mask


def pool_videos(pool: Path) -> list[Path]:
    """The pool's video files in name order: ``pool/video/*`` if it exists, else ``pool/*``."""
    folder = pool / "video" if (pool / "video").is_dir() else pool
    if not folder.is_dir():
        raise MiketalkError(f"no such pool folder: {pool}")
    videos = sorted(p for p in folder.iterdir() if p.suffix.lower() in _VIDEO_SUFFIXES)
    if not videos:
        raise MiketalkError(f"no video files in {folder}")
    return videos


def _stats(values: np.ndarray) -> tuple[float, float, float]:
    v = values[np.isfinite(values)]
    if v.size == 0:
        return (float("nan"),) * 3
    return float(np.median(v)), float(np.percentile(v, 95)), float(v.max())


def run(pool: Path, out: Path, *, limit: int | None = None) -> str:
    """Stabilize and measure the pool's clips; write the CSV and the summary; return the summary.

    Parameters
    ----------
    pool : pathlib.Path
        A folder of clips (see the module's docstring).
    out : pathlib.Path
        Folder for ``stabilization.csv`` and ``summary.md`` (created).
    limit : int, optional
        Only the first ``limit`` clips.

    Returns
    -------
    str
        The markdown summary.
    """
    videos = pool_videos(pool)[:limit]
    start = time.perf_counter()
    first, _ = read_video(videos[0])
    ref_index = choose_reference(first)
    reference = first[ref_index]
    stabilizer = Stabilizer.from_reference(reference, sample=first)
    setup_s = time.perf_counter() - start
    assert stabilizer.face is not None and stabilizer.mouth_box is not None
    target = registration_mask(stabilizer.face, stabilizer.mouth_box, region="rigid")
    whole = registration_mask(stabilizer.face, stabilizer.mouth_box, region="face")

    rows: list[tuple] = []
    seconds = {"read": 0.0, "register": 0.0, "conform": 0.0, "apply": 0.0}
    failed_frames: dict[str, int] = {}
    not_conformed: dict[str, str] = {}
    n_frames = 0
    for path in videos:
        clip = path.stem
        t0 = time.perf_counter()
        frames, _ = read_video(path)
        t1 = time.perf_counter()
        transforms = stabilizer.register(frames, clip=clip, on_failure="nan")
        t2 = time.perf_counter()
        correlations = stabilizer.correlations.copy()
        ok = np.isfinite(transforms[:, 0, 0])
        field = None
        if ok.any():
            try:
                field = stabilizer.conform(frames, transforms, clip=clip)
            except MiketalkError as err:
                not_conformed[clip] = str(err)
        t3 = time.perf_counter()
        affine = stabilizer.apply(frames[ok], transforms[ok])
        steady = (
            affine if field is None else stabilizer.apply(frames[ok], transforms[ok], field=field)
        )
        t4 = time.perf_counter()
        seconds["read"] += t1 - t0
        seconds["register"] += t2 - t1
        seconds["conform"] += t3 - t2
        seconds["apply"] += t4 - t3
        n_frames += len(frames)
        if (~ok).any():
            failed_frames[clip] = int((~ok).sum())
        before = residual_motion(frames, reference, target)
        before_face = residual_motion(frames, reference, whole)
        after = np.full(len(frames), np.nan)
        after_affine, after_face = after.copy(), after.copy()
        if ok.any():
            after[ok] = residual_motion(steady, reference, target)
            after_affine[ok] = residual_motion(affine, reference, target)
            after_face[ok] = residual_motion(steady, reference, whole)
        for k in range(len(frames)):
            rows.append(
                (clip, k, before[k], after[k], after_affine[k], before_face[k], after_face[k],
                 correlations[k], int(ok[k]))
            )  # fmt: skip
        print(
            f"{clip}: before {np.median(before):.2f} px, after {np.nanmedian(after):.2f} px"
            f" (affine only {np.nanmedian(after_affine):.2f})"
            + (f", {int((~ok).sum())} frames did not register" if (~ok).any() else ""),
            flush=True,
        )

    out.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(_COLUMNS)
    for row in rows:
        writer.writerow(
            [row[0], row[1], *(f"{v:.4f}" if np.isfinite(v) else "" for v in row[2:8]), row[8]]
        )
    write_text_atomic(out / "stabilization.csv", buffer.getvalue())

    table = np.array([r[2:7] for r in rows], dtype=float)
    names = ("before", "after", "after (affine only)", "before", "after")
    masks = ("target", "target", "target", "face", "face")
    median, p95, _ = _stats(table[:, 1])
    met = median <= TARGET_MEDIAN_PX and p95 <= TARGET_P95_PX
    lines = [
        f"# Stabilization: {len(videos)} clips, {n_frames} frames of {pool}",
        "",
        f"Reference: frame {ref_index} of {videos[0].stem}; mouth box "
        f"{stabilizer.mouth_box}; registered on {int(stabilizer.mask.sum())} px, target mask "
        f"{int(target.sum())} px, face mask {int(whole.sum())} px.",
        "",
        "Residual motion (mean DIS-flow magnitude from the reference over the mask, px per frame):",
        "",
        "| mask | frames | median | p95 | max |",
        "| --- | --- | --- | --- | --- |",
    ]
    for j, (name, mask) in enumerate(zip(names, masks, strict=True)):
        lines.append(f"| {mask} | {name} | {' | '.join(f'{v:.3f}' for v in _stats(table[:, j]))} |")
    lines += [
        "",
        f"Target (target mask, after): median <= {TARGET_MEDIAN_PX} px and p95 <= "
        f"{TARGET_P95_PX} px: {'met' if met else 'NOT met'}.",
        "",
        "Time (ms per frame; register = the affine ECC registration, conform = the clip's "
        "field, per frame of the clip):",
        "",
        "| read | register | conform | apply | setup (s) |",
        "| --- | --- | --- | --- | --- |",
        "| "
        + " | ".join(f"{1000 * seconds[k] / n_frames:.2f}" for k in seconds)
        + f" | {setup_s:.2f} |",
        "",
        f"Frames that did not register: {sum(failed_frames.values())}"
        + "".join(f"\n- {c}: {n} frames" for c, n in failed_frames.items()),
        f"Clips without a conform field: {len(not_conformed)}"
        + ("".join(f"\n- {c}: {why}" for c, why in not_conformed.items())),
    ]  # fmt: skip
    summary = "\n".join(lines) + "\n"
    write_text_atomic(out / "summary.md", summary)
    return summary


def main(argv: Sequence[str] | None = None) -> int:
    """Stabilize a pool's clips and measure the residual motion.

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
    parser.add_argument("--pool", type=Path, required=True, help="a folder of clips (GRID-style)")
    parser.add_argument(
        "--out",
        type=Path,
        default=defaults.RESULTS / "bench" / "stabilization",
        help="output folder",
    )
    return run_bench(parser, argv, lambda args: run(args.pool, args.out, limit=args.limit))


if __name__ == "__main__":
    sys.exit(main())
