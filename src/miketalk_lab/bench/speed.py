"""Speed: ``say`` and ``dub`` timed as a user runs them, and the 720p render's throughput.

``python -m miketalk_lab.bench speed`` (``make bench``, after ``make run``), or
``python -m miketalk_lab.bench.speed --out OUT [--runs N] [--obama DIR] [--s1 MODEL]``.
Issue 51's targets (2 cores, warm, medians of 5 whole-command runs):

- ``say`` of 10 words to an mp4 on s1 (``results/model/s1``, the workflow's: made by
  ``snakemake results/model/s1`` when ``make run`` has not), **at most 1.0 s**;
- the same on a 720p model built from the weekly addresses (``miketalk build`` of every
  address but wa06 and wa08, as :mod:`miketalk_lab.bench.anyone` builds its first fold; its
  model is reused when that bench made it), **at most 2.0 s**;
- the 720p model's render (the drawing and the compositing into its 1280x720 frames, in the
  encoder's colours) on **one** core, **at least 1.5x real time** (the other core is
  Festival's, the encoder's and the page's);
- ``dub`` of 10 s of 720p (wa06, wa07 and wa08 joined, 10.14 s, dubbed with their own
  recording and caption lines), **at most 5 s**: timed as a first dub of the video (the
  kept registrations removed before each run, :func:`forget_registrations`), and again as
  a second dub (``hd_dub_10s_again``: its registration read from the cache,
  :mod:`miketalk.composite.kept_registration`);
- issue 53's one-command ``dub VIDEO --audio VIDEO`` with no ``--model`` and no ``--text``
  (the video's own model, built from it by the unmeasured first run into a cache of the
  bench's own, ``OUT/work/cache``; its words recognized), the second time, **at most 10 s**
  (``hd_dub_10s_own_model_again``).

The 720p dub's CPU is also split by part, one run of the first dub and one of the second
(:mod:`miketalk_lab.bench.dub_parts`: the producer's registration and compositing, the
drawing's threads, the alignment's child, x264, the decoders; ``*_cpu_part_*`` figures and
a table in ``summary.md``): what holds the dub above its target.

Each command runs once unmeasured (warm: the model's check and decoded frames kept in the
user's cache, :mod:`miketalk.media.user_cache`; the page cache full), then :data:`RUNS`
times; each figure is the median with its min and max, its wall time from start to exit
and its CPU (user + system of it and its children, ``resource.getrusage``), with the load
average before and after: on a shared machine a slow wall with a steady CPU is the load's.
The package's bytecode is compiled first (``compileall``), as a wheel's install does: an
editable install under ``PYTHONDONTWRITEBYTECODE`` would otherwise compile every module at
every run. Writes ``OUT/timings.csv`` and ``OUT/summary.md``.
"""

from __future__ import annotations

import csv
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[3]
S1_SENTENCE = "Bin blue at F two now and lay green by G soon."
HD_SENTENCE = "We will build a stronger economy for every family in America."
#: The addresses the 720p model leaves out (the anyone bench's first fold).
HELD = ("wa06", "wa08")
#: The addresses joined into the video dubbed: 10.14 s (the two held out, and wa07).
DUBBED = ("wa06", "wa07", "wa08")
RUNS = 5
#: Each target: (figure, at most / at least, bound).
TARGETS = {
    "s1_say_10_words": ("<=", 1.0),
    "hd_say_10_words": ("<=", 2.0),
    "hd_render_one_core_x_realtime": (">=", 1.5),
    "hd_dub_10s": ("<=", 5.0),
    "hd_dub_10s_again": ("<=", 5.0),
    "hd_dub_10s_own_model_again": ("<=", 10.0),
}


def timed(
    command: Sequence[str], runs: int = RUNS, *, before_each=None, env: dict | None = None
) -> dict[str, float]:
    """``command`` run once unmeasured, then ``runs`` times: wall and CPU median, min, max
    (``before_each()`` called before each run, unmeasured; ``env``: the environment)."""
    import resource

    walls, cpus, loads = [], [], []
    for i in range(runs + 1):
        if before_each is not None:
            before_each()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        loads.append(os.getloadavg()[0])
        started = time.monotonic()
        subprocess.run(command, check=True, capture_output=True, env=env)
        wall = time.monotonic() - started
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if i:
            walls.append(wall)
            cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    loads.append(os.getloadavg()[0])
    return {
        "median": statistics.median(walls), "min": min(walls), "max": max(walls),
        "cpu_median": statistics.median(cpus), "cpu_min": min(cpus), "cpu_max": max(cpus),
        "load_before": loads[0], "load_after": loads[-1],
    }  # fmt: skip


def forget_registrations() -> None:
    """The user's cache's kept registrations removed (:mod:`miketalk.composite.
    kept_registration`): the next dub tracks and registers its video, as a first dub does
    (the model's checks and decoded frames stay kept)."""
    import shutil

    from miketalk.composite.kept_registration import KIND
    from miketalk.media.user_cache import cache_dir

    kept = cache_dir(KIND)  # None: no cache (``$MIKETALK_CACHE=off``), nothing kept
    if kept is not None:
        shutil.rmtree(kept, ignore_errors=True)


def render_throughput(model: Path, timeline_json: Path) -> dict[str, float]:
    """Frames drawn and composited (I420) per second of one core, over the seconds they
    play: the x real time of the 720p render (a process held to one processor, one
    OpenCV thread, one drawing worker)."""
    code = f"""
import os, time, json, cv2
os.sched_setaffinity(0, {{sorted(os.sched_getaffinity(0))[0]}})
cv2.setNumThreads(1)
import miketalk.workers
miketalk.workers.RENDER_WORKERS = 1  # before the drawing's modules bind it
from miketalk.composite.for_model import MouthCompositing
from miketalk.model.face import open_model
from miketalk.talk.utterance import read_said
said = read_said({str(timeline_json)!r})
model = open_model({str(model)!r})
best = None
for _ in range(3):
    started = time.process_time(); wall = time.perf_counter()
    comp = MouthCompositing(model, model.background())
    drawing = model.drawing(said.lipsync_model, recorded=False)
    frames, _, _ = drawing.frames(model, said.timeline, max_px_per_frame=said.max_px_per_frame,
                                  region=comp.region)
    n = sum(1 for _ in comp.frames(frames, fps=said.timeline.fps, i420=True))
    spent = (time.process_time() - started, time.perf_counter() - wall)
    best = spent if best is None or spent[1] < best[1] else best
print(json.dumps({{"frames": n, "cpu": best[0], "wall": best[1], "fps": said.timeline.fps}}))
"""
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True
    ).stdout
    import json

    got = json.loads(out.strip().splitlines()[-1])
    seconds = got["frames"] / got["fps"]
    return {"x_realtime_wall": seconds / got["wall"], "x_realtime_cpu": seconds / got["cpu"],
            "frames": got["frames"], "load": os.getloadavg()[0]}  # fmt: skip


def x264_settings(video: Path, work: Path) -> dict[str, dict[str, float]]:
    """The file writer's and the live stream's x264 settings
    (:data:`~miketalk.media.x264.FILE_X264`, :data:`~miketalk.media.x264.LIVE_X264`) on the
    same 720p frames (``video`` decoded to yuv420p once): the encoder's CPU (one thread),
    the bytes, and PSNR against the frames given."""
    import re
    import resource

    from miketalk.media.x264 import FILE_X264, LIVE_X264, ffmpeg_exe

    work.mkdir(parents=True, exist_ok=True)
    exe, raw = ffmpeg_exe(), work / "frames.yuv"
    subprocess.run([exe, "-v", "error", "-y", "-i", str(video), "-f", "rawvideo", "-pix_fmt",
                    "yuv420p", str(raw)], check=True)  # fmt: skip
    from miketalk.media.decode import video_info

    width, height, fps = video_info(video)
    source = ["-f", "rawvideo", "-pix_fmt", "yuv420p", "-s", f"{width}x{height}", "-r",
              f"{fps}", "-i", str(raw)]  # fmt: skip
    out = {}
    for name, x264 in (("file", FILE_X264), ("live", LIVE_X264)):
        mp4 = work / f"x264_{name}.mp4"
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([exe, "-v", "error", "-y", *source, *x264.args(), "-threads", "1",
                        "-pix_fmt", "yuv420p", str(mp4)], check=True)  # fmt: skip
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        psnr = subprocess.run([exe, "-i", str(mp4), *source, "-lavfi", "psnr", "-f", "null", "-"],
                              capture_output=True, text=True, check=True).stderr  # fmt: skip
        frames = raw.stat().st_size // (width * height * 3 // 2)
        out[name] = {
            "cpu_ms_per_frame": 1000 * (after.ru_utime - before.ru_utime) / frames,
            "megabytes": mp4.stat().st_size / 1e6,
            "psnr_db": float(re.findall(r"average:([0-9.]+)", psnr)[-1]),
        }
    raw.unlink()
    return out


def s1_model() -> Path:
    """``results/model/s1`` of the workflow, made with its stages when missing."""
    model = ROOT / "results" / "model" / "s1"
    if not (model / "manifest.json").is_file():
        subprocess.run(
            [sys.executable, "-m", "snakemake", "--cores", "2", "--rerun-incomplete",
             "results/model/s1"], check=True, cwd=ROOT,
        )  # fmt: skip
    return model


def hd_model(obama: Path, work: Path) -> Path:
    """The anyone bench's first fold's model (every address but :data:`HELD`), reused from
    that bench's work folder when it made it, else built in ``work``."""
    from miketalk_lab.bench.anyone import _fold_model

    theirs = work.parent.parent / "anyone" / "work" / f"model_{'_'.join(HELD)}"
    if (theirs / "manifest.json").is_file():
        return theirs
    ids = sorted(p.stem for p in (obama / "video").glob("wa*.mp4"))
    return _fold_model(obama, work, HELD, ids)["model"]


def run(out_dir: Path) -> dict[str, float]:
    """Every figure of the module docstring (``make bench``)."""
    config = yaml.safe_load((ROOT / ".bench" / "anyone" / "config.yaml").read_text())
    return measure(out_dir, (ROOT / config["obama"]).resolve())


def measure(out_dir: Path, obama: Path, *, runs: int = RUNS, s1: Path | None = None) -> dict:
    """Time everything, write ``timings.csv`` and ``summary.md``; the figures."""
    from miketalk_lab.bench.bad_input import join_addresses

    out_dir.mkdir(parents=True, exist_ok=True)
    work = out_dir / "work"
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(ROOT / "src" / "miketalk")],
                   check=True, capture_output=True)  # fmt: skip
    miketalk = [sys.executable, "-m", "miketalk.cli"]
    s1 = s1 or s1_model()
    hd = hd_model(obama, work)
    rows: dict[str, dict[str, float]] = {}
    out = work / "out"
    rows["s1_say_10_words"] = timed(
        [*miketalk, "say", S1_SENTENCE, "--model", str(s1), "-o", str(out / "s1.mp4"), "--force"],
        runs,
    )
    rows["hd_say_10_words"] = timed(
        [*miketalk, "say", HD_SENTENCE, "--model", str(hd), "-o", str(out / "hd.mp4"), "--force"],
        runs,
    )
    throughput = render_throughput(hd, out / "hd.json")
    joined = join_addresses(obama, work, DUBBED, "dubbed_" + "_".join(DUBBED))
    stem = work / ("dubbed_" + "_".join(DUBBED))
    text = stem.with_suffix(".txt").read_text("utf-8").replace("\n", " ").strip()
    video = str(stem.with_suffix(".mp4"))
    dub = [*miketalk, "dub", video, "--audio", video, "--text", text, "--model", str(hd),
           "-o", str(out / "dub.mp4"), "--force"]  # fmt: skip
    rows["hd_dub_10s"] = timed(dub, runs, before_each=forget_registrations)
    rows["hd_dub_10s_again"] = timed(dub, runs)  # its registration kept from the run before
    forget_registrations()  # where the CPU goes, part by part: one run of each
    parts = {name: dub_parts(dub[len(miketalk) :], work / f"parts_{name}.json")
             for name in ("hd_dub_10s", "hd_dub_10s_again")}  # fmt: skip
    # issue 53: no --model, no --text: the video's own model (built by the unmeasured first
    # run into a cache of the bench's own) and its words recognized
    own = {**os.environ, "MIKETALK_CACHE": str(work / "cache")}
    rows["hd_dub_10s_own_model_again"] = timed(
        [*miketalk, "dub", video, "--audio", video, "-o", str(out / "own.mp4"), "--force"],
        runs, env=own,
    )  # fmt: skip
    dubbed_seconds = joined["frames"] / joined["fps"]
    encoders = x264_settings(Path(video), work)
    with (out_dir / "timings.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["command", *next(iter(rows.values())).keys()])
        for name, row in rows.items():
            writer.writerow([name, *(f"{v:.3f}" for v in row.values())])
    figures: dict[str, float] = {}
    for name, row in rows.items():
        figures |= {
            f"{name}_seconds": row["median"],
            f"{name}_min_seconds": row["min"],
            f"{name}_max_seconds": row["max"],
            f"{name}_cpu_seconds": row["cpu_median"],
        }
    figures["hd_render_one_core_x_realtime"] = throughput["x_realtime_wall"]
    figures["hd_render_one_core_x_realtime_cpu"] = throughput["x_realtime_cpu"]
    figures["hd_dub_video_s"] = dubbed_seconds  # fmt: skip
    for name, row in encoders.items():
        figures |= {f"x264_{name}_{k}": v for k, v in row.items()}
    for name, found in parts.items():
        figures |= {f"{name}_cpu_part_{_slug(part)}": v for part, v in found["parts"].items()}
    (out_dir / "summary.md").write_text(
        summary(rows, throughput, dubbed_seconds, runs, encoders) + parts_table(parts),
        encoding="utf-8",
    )
    return figures


def dub_parts(args: Sequence[str], out: Path) -> dict:
    """One run of ``miketalk`` ``args`` under :mod:`miketalk_lab.bench.dub_parts`: the CPU
    seconds of each part (written to ``out``)."""
    import json

    subprocess.run([sys.executable, "-m", "miketalk_lab.bench.dub_parts", str(out), "--", *args],
                   check=True, capture_output=True)  # fmt: skip
    return json.loads(out.read_text("utf-8"))


def _slug(part: str) -> str:
    """A part's name as a figure's: ``x264 encoder (ffmpeg)`` -> ``x264_encoder``."""
    return "_".join(part.split(" (")[0].replace(",", "").split())


def parts_table(parts: dict[str, dict]) -> str:
    """The 720p dub's CPU by part, first and again (one run each)."""
    names = list(parts)
    order = list(dict.fromkeys(p for found in parts.values() for p in found["parts"]))
    lines = [
        "720p dub of 10 s: CPU seconds by part, one run of each under a sampler "
        "(`miketalk_lab.bench.dub_parts`; unattributed: CPU after a part's last reading)",
        "",
        "| part | " + " | ".join(names) + " |",
        "| --- |" + " --- |" * len(names),
        *(f"| {p} | " + " | ".join(f"{parts[n]['parts'].get(p, 0.0):.2f}" for n in names) + " |"
          for p in order),
        "| unattributed | " + " | ".join(f"{parts[n]['unattributed']:.2f}" for n in names) + " |",
        "| **total** | " + " | ".join(f"**{parts[n]['total']:.2f}**" for n in names) + " |",
        "",
    ]  # fmt: skip
    return "\n".join(lines)


def summary(rows: dict, throughput: dict, dubbed_seconds: float, runs: int, encoders: dict) -> str:
    """The timing table (median, min, max; CPU; load) against the targets, and x264's."""
    lines = [
        f"# Speed (issue 51): medians of {runs} whole-command runs after one unmeasured",
        "",
        "| command | target | wall median (s) | min | max | CPU median (s) | load before/after |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, row in rows.items():
        op, bound = TARGETS[name]
        lines.append(
            f"| {name} | {op} {bound:g} s | {row['median']:.2f} | {row['min']:.2f} | "
            f"{row['max']:.2f} | {row['cpu_median']:.2f} | "
            f"{row['load_before']:.1f} / {row['load_after']:.1f} |"
        )
    op, bound = TARGETS["hd_render_one_core_x_realtime"]
    lines += [
        "",
        f"720p render on one core ({throughput['frames']} frames, drawing and compositing "
        f"in I420; target {op} {bound:g}x real time): **{throughput['x_realtime_wall']:.2f}x** "
        f"real time by the wall, {throughput['x_realtime_cpu']:.2f}x by its CPU "
        f"(load {throughput['load']:.1f}). The dubbed video lasts {dubbed_seconds:.2f} s.",
        "",
        "x264 on the dubbed video's 720p frames (yuv420p in, one thread):",
        "",
        "| settings | CPU ms a frame | MB | PSNR (dB) |",
        "| --- | --- | --- | --- |",
        *(f"| {name} | {r['cpu_ms_per_frame']:.2f} | {r['megabytes']:.2f} | {r['psnr_db']:.2f} |"
          for name, r in encoders.items()),
        "",
    ]  # fmt: skip
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m miketalk_lab.bench.speed``."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.speed")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--obama", type=Path, default=ROOT.parent / "shared" / "data" / "obama")
    parser.add_argument("--s1", type=Path, default=None, help="an s1 model (default: made)")
    parser.add_argument("--runs", type=int, default=RUNS)
    args = parser.parse_args(argv)
    measure(args.out, args.obama, runs=args.runs, s1=args.s1)
    print((args.out / "summary.md").read_text("utf-8"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
