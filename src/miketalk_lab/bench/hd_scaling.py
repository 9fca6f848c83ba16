"""Time and memory of ``miketalk build``, ``say`` and ``dub`` by the video's resolution and length.

``python -m miketalk_lab.bench.hd_scaling --pool DIR --out OUT [--lengths 2 10]
[--heights 288 720 1080] [--work /tmp/bench39] [--skip LxH ...] [--say-heights 720]``
joins the pool's first ``20 * minutes`` clips (GRID clips last 3 s: 40 clips make 2
minutes, all 200 make 10; :mod:`miketalk_lab.bench.joined`, x264 crf 18), upscales the
join to each height keeping the aspect (``scale=-2:H,pad=W:H:(ow-iw)/2:0``: 1280x720,
1920x1080; 288 is the clips' own 360x288), and builds a model from each video with
``miketalk build VIDEO --transcript T -o MODEL`` (the default ``--frame crop``), one build
after the other, each under ``/usr/bin/time -f "%e %M %U %S"``. Per build: wall time, CPU
time (user + system over its processes), the largest resident memory of one of its processes
(``%M``: ``ru_maxrss`` of a child tree is its largest process's, not their sum), the largest
sum over its processes (``/proc`` sampled every second: RSS, and PSS, which counts pages
shared by forked workers once), the build's own per-stage peaks (``stage_peak_mb``), the
model's size on disk (``du``) and the machine's 1-minute load average during the run.

Then, with each model of ``--say-heights``: a *warm* ``say`` (the model opened once in a
process, :func:`warm_say`: several 10-word sentences, Festival speaking included, each
timed), a cold ``miketalk say`` on the command line, and ``miketalk dub`` of a
10-second clip of that height (seconds 300 to 310 of the 10-minute video when there is
one, else 60 to 70 of the 2-minute one: frames the 2-minute model never saw).

Inputs and models stay in ``--work`` (reused when there: delete them to remake them); a
build already measured (``OUT/runs/<name>.json``) is not run again (``--rerun``). Writes
``OUT/hd_scaling.tsv`` and ``OUT/hd_scaling.md`` and prints the markdown.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import re
import subprocess
import sys
import threading
import time
from collections.abc import Sequence

from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench

ROOT = pathlib.Path(__file__).resolve().parents[3]
#: GRID's clips last 3 s: this many make a minute.
CLIPS_PER_MINUTE = 20
#: Frame size of each height (288: the clips' own).
SIZES = {288: (360, 288), 720: (1280, 720), 1080: (1920, 1080)}
#: Ten-word sentences for the warm ``say`` (none of them GRID's).
SENTENCES = (
    "Please call me when you arrive at the station tonight.",
    "The weather today is much warmer than it was yesterday.",
    "We will meet again next week to finish the plan.",
    "She bought three green apples and a loaf of bread.",
    "Turn left at the corner and walk two more blocks.",
    "My brother plays the piano every evening after his dinner.",
)
#: What ``dub`` says over its 10-second clip (about ten seconds of Festival's speech).
DUB_TEXT = (
    "Good morning everyone. Today we are looking at a new way to make a video speak, "
    "and the results so far are better than we hoped when we started the work."
)
#: Targets of issue 39.
TARGET_BUILD_MB, TARGET_TIME_RATIO, TARGET_WARM_SAY_S, TARGET_DUB_S = 4096, 1.5, 3.0, 20.0


def scale_filter(height: int) -> str | None:
    """ffmpeg's filter from 360x288 to ``height`` keeping the aspect (None: the clips' own)."""
    width, high = SIZES[height]
    if height == 288:
        return None
    return f"scale=-2:{high},pad={width}:{high}:(ow-iw)/2:0"


def run_name(minutes: int, height: int) -> str:
    """A run's name: ``2min_720p``."""
    return f"{minutes}min_{height}p"


def parse_time_file(text: str) -> tuple[float, float, float]:
    """``/usr/bin/time -f "%e %M %U %S"``'s last line: wall seconds, peak MB, CPU seconds."""
    wall, kb, user, system = text.strip().splitlines()[-1].split()
    return float(wall), int(kb) / 1024, float(user) + float(system)


def human_size(n_bytes: int) -> str:
    """``du -h``-like: 304M, 1.8G."""
    for unit, size in (("G", 1 << 30), ("M", 1 << 20), ("K", 1 << 10)):
        if n_bytes >= size:
            value = n_bytes / size
            return f"{value:.1f}{unit}" if value < 10 else f"{value:.0f}{unit}"
    return f"{n_bytes}B"


def minutes_seconds(seconds: float) -> str:
    """``9m53s``."""
    return f"{int(seconds // 60)}m{round(seconds % 60):02d}s"


class TreeSampler(threading.Thread):
    """Samples, every ``interval`` s, the summed RSS and PSS (MB) of ``pid`` and its
    descendants, and the 1-minute load average; the largest sums and the mean load."""

    def __init__(self, pid: int, interval: float = 1.0) -> None:
        super().__init__(daemon=True)
        self.pid, self.interval = pid, interval
        self.rss_mb = self.pss_mb = 0.0
        self.loads: list[float] = []
        self._done = threading.Event()

    def run(self) -> None:
        while not self._done.wait(self.interval):
            rss, pss = _tree_memory(self.pid)
            self.rss_mb, self.pss_mb = max(self.rss_mb, rss), max(self.pss_mb, pss)
            self.loads.append(os.getloadavg()[0])

    def stop(self) -> dict:
        self._done.set()
        self.join()
        mean = sum(self.loads) / len(self.loads) if self.loads else os.getloadavg()[0]
        return {"tree_rss_mb": self.rss_mb, "tree_pss_mb": self.pss_mb, "load_mean": mean}


def _tree_memory(root: int) -> tuple[float, float]:
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = pathlib.Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            children.setdefault(ppid, []).append(int(entry))
    rss = pss = 0.0
    todo = [root]
    while todo:
        pid = todo.pop()
        todo += children.get(pid, [])
        try:
            for line in pathlib.Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
                if line.startswith(("Rss:", "Pss:")):
                    kb = int(line.split()[1]) / 1024
                    rss, pss = (rss + kb, pss) if line.startswith("Rss") else (rss, pss + kb)
        except (OSError, ValueError, IndexError):
            continue
    return rss, pss


def measured(command: Sequence[str], log: pathlib.Path) -> dict:
    """Run ``command`` under ``/usr/bin/time``, its stderr into ``log`` (its stdout beside it,
    ``.out``): wall and CPU time, peak memory (largest process; summed over the tree), load,
    and a failure's last line of stderr."""
    timing = log.with_suffix(".time")
    load_start = os.getloadavg()[0]
    with open(log, "w") as err, open(log.with_suffix(".out"), "w") as out:
        proc = subprocess.Popen(
            ["/usr/bin/time", "-f", "%e %M %U %S", "-o", str(timing), *command],
            stdout=out, stderr=err,
        )  # fmt: skip
        sampler = TreeSampler(proc.pid)
        sampler.start()
        code = proc.wait()
    result = sampler.stop() | {"load_start": load_start, "returncode": code}
    wall, peak, cpu = parse_time_file(timing.read_text())
    if code:
        lines = [x for x in re.split(r"[\r\n]", log.read_text(errors="replace")) if x.strip()]
        result["error"] = lines[-1] if lines else "(no output)"
    return result | {"wall_s": wall, "peak_mb": peak, "cpu_s": cpu}


def make_inputs(pool: pathlib.Path, work: pathlib.Path, minutes: int, heights) -> dict:
    """The joined video of ``minutes`` and its upscales: height -> (video, transcript)."""
    from miketalk_lab.bench.joined import join_clips

    n = CLIPS_PER_MINUTE * minutes
    joined = work / f"join_{n}"
    if not (joined / "joined.mp4").exists():
        ids = sorted(p.stem for p in (pool / "video").glob("*.mpg"))[:n]
        if len(ids) < n:
            raise MiketalkError(f"{pool}: {len(ids)} clips, {minutes} minutes need {n}")
        join_clips(
            ids, joined, media=str(pool / "video" / "{id}.mpg"),
            transcripts=pool / "transcripts.txt", timings=str(pool / "align" / "{id}.align"),
            crf=18,
        )  # fmt: skip
    videos = {}
    for height in heights:
        video = (
            joined / "joined.mp4" if height == 288 else work / f"{run_name(minutes, height)}.mp4"
        )
        if not video.exists():
            ffmpeg(["-i", str(joined / "joined.mp4"), "-vf", scale_filter(height)], video)
        videos[height] = (video, joined / "transcript.txt")
    return videos


def ffmpeg(arguments: Sequence[str], out: pathlib.Path) -> None:
    """ffmpeg ``arguments`` to an H.264 (crf 18, yuv420p) mp4 with the sound copied, atomically."""
    import imageio_ffmpeg

    part = out.with_name(f".{out.name}.part.mp4")
    command = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", *arguments,
        "-c:v", "libx264", "-preset", "veryfast", "-crf", "18", "-pix_fmt", "yuv420p",
        "-c:a", "copy", str(part),
    ]  # fmt: skip
    subprocess.run(command, check=True)
    part.rename(out)


def miketalk(*arguments: str) -> list[str]:
    """The command line of ``miketalk ARGUMENTS`` in this venv."""
    return [str(pathlib.Path(sys.executable).parent / "miketalk"), *arguments]


def du(path: pathlib.Path) -> int:
    """Bytes on disk under ``path`` (``du -sk``, as ``du -sh`` counts them)."""
    return 1024 * int(subprocess.check_output(["du", "-sk", str(path)], text=True).split()[0])


def build(name: str, video, transcript, work: pathlib.Path, runs: pathlib.Path) -> dict:
    """``miketalk build`` of one video, measured; its result is also ``runs/NAME.json``."""
    model = work / "models" / name
    log = runs / f"{name}.build.log"
    started, at = time.strftime("%Y-%m-%d %H:%M:%S"), commit()
    result = measured(
        miketalk("build", str(video), "--transcript", str(transcript), "-o", str(model),
                 "--force", "--json"),
        log,
    )  # fmt: skip
    result |= {"kind": "build", "name": name, "started": started, "commit": at}
    if result["returncode"] == 0:
        doc = json.loads(log.with_suffix(".out").read_text("utf-8"))
        result |= {"build": doc, "model_bytes": du(model)}
    else:
        stages = re.findall(r"miketalk build: ([^:\r\n]+): [\d.]+ s", log.read_text("utf-8"))
        result["last_stage_done"] = stages[-1] if stages else None
    (runs / f"{name}.json").write_text(json.dumps(result, indent=1) + "\n", "utf-8")
    return result


def commit() -> str:
    """HEAD's short hash, with ``+N`` product files changed in the working tree."""
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()  # fmt: skip
    status = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "src/miketalk"],
                            capture_output=True, text=True).stdout.splitlines()  # fmt: skip
    return f"{head}+{len(status)}" if status else head


def warm_say(model_dir: str, out_dir: str, sentences: Sequence[str] = SENTENCES) -> dict:
    """Open the model once, then time ``say`` of each sentence (Festival speaking included),
    as ``miketalk say`` calls the library (:func:`miketalk.cli.say.cmd_say`)."""
    from miketalk import defaults
    from miketalk.composite.for_model import resolve_background
    from miketalk.lipsync.settings import LipsyncSettings
    from miketalk.speech import get_backend
    from miketalk.talk.say import open_model, say

    started = time.perf_counter()
    model = open_model(model_dir)
    opened = time.perf_counter()
    background = resolve_background("auto", model)
    resolved = time.perf_counter()
    in_crop = background is not None and model.crop is not None
    settings = LipsyncSettings(
        fps=background.fps if in_crop else defaults.FPS,
        model=model.choose_lipsync_model(None, recorded=False).value,
    )
    seconds, frames = [], []
    for i, text in enumerate(sentences):
        begin = time.perf_counter()
        with get_backend("festival", voice="kal").start(text) as speech:
            spoken = say(speech, pathlib.Path(out_dir) / f"warm{i}.mp4", model=model,
                         settings=settings, background=background, overwrite=True)  # fmt: skip
        seconds.append(time.perf_counter() - begin)
        frames.append(spoken.motion.frames)
    model.close()
    return {
        "open_s": opened - started, "background_s": resolved - opened, "say_s": seconds,
        "frames": frames, "fps": settings.fps, "size": list(background.size) if in_crop else None,
        "peak_mb": _vm_hwm_mb(),
    }  # fmt: skip


def _vm_hwm_mb() -> float:
    status = pathlib.Path("/proc/self/status").read_text()
    return int(status.split("VmHWM:")[1].split()[0]) / 1024


def say_and_dub(name: str, model: pathlib.Path, clip: pathlib.Path, runs: pathlib.Path) -> dict:
    """The warm ``say`` (in a child process of its own), a cold ``miketalk say`` (twice) and
    ``miketalk dub`` of ``clip`` with the model ``model``, measured."""
    out = runs / f"{name}.say"
    out.mkdir(parents=True, exist_ok=True)
    code = "import json,sys; from miketalk_lab.bench.hd_scaling import warm_say as w; "
    code += "print(json.dumps(w(sys.argv[1], sys.argv[2])))"
    commands = {
        "warm": [sys.executable, "-c", code, str(model), str(out)],
        "cold0": miketalk("say", SENTENCES[0], "-o", f"{out}/cold.mp4", "--model", str(model)),
        "cold1": miketalk("say", SENTENCES[1], "-o", f"{out}/cold.mp4", "--model", str(model)),
        "dub": miketalk("dub", str(clip), "--text", DUB_TEXT, "-o", f"{out}/dub.mp4",
                        "--model", str(model), "--json"),
    }  # fmt: skip
    result: dict = {"kind": "say_dub", "name": name, "commit": commit()}
    for key, command in commands.items():
        log = runs / f"{name}.{key}.log"
        result[key] = measured([*command, "--force"] if key != "warm" else command, log)
        if key == "warm" and not result[key]["returncode"]:
            result[key]["calls"] = json.loads(log.with_suffix(".out").read_text("utf-8"))
    (runs / f"{name}.say.json").write_text(json.dumps(result, indent=1) + "\n", "utf-8")
    return result


def dub_clip(work: pathlib.Path, videos: dict, height: int) -> pathlib.Path:
    """10 seconds of the longest video of ``height``: from 300 s of a 10-minute one (else 60 s)."""
    minutes = max(m for m, h in videos if h == height)
    clip = work / f"dub10s_{height}p.mp4"
    if not clip.exists():
        start = "300" if minutes >= 10 else "60"
        ffmpeg(["-ss", start, "-i", str(videos[minutes, height][0]), "-t", "10"], clip)
    return clip


def tables(builds: dict, says: dict, command: str) -> tuple[str, str]:
    """The TSV and the markdown of the measures."""
    keys = ("wall_s", "cpu_s", "peak_mb", "tree_pss_mb", "tree_rss_mb", "load_start", "load_mean")
    tsv = ["\t".join(("kind", "run", *keys, "stage_peak_mb", "model_bytes", "commit", "error"))]
    md = [
        "| resolution | length | build wall | CPU | peak MB (largest process) | peak MB (tree PSS) "
        "| build's own peak MB | model on disk | load (start / mean) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    stages = ["", "Stage seconds (the build's own peak MB after each stage):", ""]
    for (minutes, height), r in sorted(builds.items(), key=lambda kv: kv[0][::-1]):
        own = max(r["build"]["stage_peak_mb"].values()) if "build" in r else ""
        size = r.get("model_bytes", "")
        tsv.append(_tsv_row("build", r, keys, own, size))
        width, high = SIZES[height]
        wall = f"failed: {r['error']}" if r.get("error") else minutes_seconds(r["wall_s"])
        md.append(
            f"| {width}x{high} | {minutes} min | {wall} | {minutes_seconds(r['cpu_s'])} | "
            f"{r['peak_mb']:.0f} | "
            f"{r['tree_pss_mb']:.0f} | {own} | {human_size(size) if size else '-'} | "
            f"{r['load_start']:.1f} / {r['load_mean']:.1f} |"
        )
        if "build" in r:
            peaks = r["build"]["stage_peak_mb"]
            parts = (
                f"{k} {v:.0f} s ({peaks.get(k, 0)})" for k, v in r["build"]["stage_seconds"].items()
            )
            stages.append(f"- {r['name']} ({r['commit']}): " + ", ".join(parts))
    md += [*stages, "", *_ratios(builds), ""]
    md += [
        "| model | warm say s (each call) | open + background s | warm peak MB | cold CLI say s "
        "| dub 10 s clip s | dub peak MB (largest / tree PSS) | load mean (warm / dub) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, r in sorted(says.items()):
        warm, dub, calls = r["warm"], r["dub"], r["warm"].get("calls", {})
        cold = [r[k]["wall_s"] for k in ("cold0", "cold1")]
        for key in ("warm", "cold0", "cold1", "dub"):
            tsv.append(_tsv_row(key, r[key] | {"name": name, "commit": r["commit"]}, keys))
        failed = " ".join(f"{k} failed: {r[k]['error']}" for k in r if "error" in r.get(k, {}))
        md.append(
            f"| {name} | {' / '.join(f'{s:.2f}' for s in calls.get('say_s', []))} | "
            f"{calls.get('open_s', 0):.2f} + {calls.get('background_s', 0):.2f} | "
            f"{calls.get('peak_mb', 0):.0f} | {' / '.join(f'{s:.1f}' for s in cold)} | "
            f"{dub['wall_s']:.1f} | {dub['peak_mb']:.0f} / {dub['tree_pss_mb']:.0f} | "
            f"{warm['load_mean']:.1f} / {dub['load_mean']:.1f} |{failed}"
        )
    return "\n".join(tsv) + "\n", "\n".join([*md, "", f"Command: `{command}`"]) + "\n"


def _tsv_row(kind: str, r: dict, keys, own="", size="") -> str:
    values = (f"{r[k]:.2f}" for k in keys)
    return "\t".join(
        (kind, r["name"], *values, str(own), str(size), r["commit"], r.get("error", ""))
    )


def _ratios(builds: dict) -> list[str]:
    lines = []
    for minutes in sorted({m for m, _ in builds}):
        low = builds.get((minutes, 288), {})
        for height in (720, 1080):
            high = builds.get((minutes, height), {})
            if "build" in low and "build" in high:
                ratio, cpu = high["wall_s"] / low["wall_s"], high["cpu_s"] / low["cpu_s"]
                met = "met" if ratio <= TARGET_TIME_RATIO else "NOT met"
                lines.append(
                    f"- {minutes} min, {height}p / 288p build time: {ratio:.2f}x (target <= "
                    f"{TARGET_TIME_RATIO}x: {met}; CPU time {cpu:.2f}x)"
                    f"; peak {high['peak_mb']:.0f} MB (largest process), {high['tree_pss_mb']:.0f}"
                    f" MB (tree PSS), target <= {TARGET_BUILD_MB} MB"
                )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Make the inputs, build, say and dub, measured; see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="unused (the lengths pick the clips)")
    parser.add_argument("--pool", type=pathlib.Path, required=True, help="a GRID-style folder")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="folder for the results")
    parser.add_argument("--work", type=pathlib.Path, default=pathlib.Path("/tmp/bench39"))
    parser.add_argument("--lengths", type=int, nargs="+", default=[2, 10], help="minutes")
    heights = sorted(SIZES)
    parser.add_argument("--heights", type=int, nargs="+", default=heights, choices=heights)
    parser.add_argument("--skip", nargs="*", default=["10min_1080p"], help="runs not built")
    parser.add_argument("--say-heights", type=int, nargs="*", default=[720])
    parser.add_argument("--rerun", action="store_true", help="measure again what was measured")
    return run_bench(parser, argv, _run)


def _run(args: argparse.Namespace) -> str:
    runs = args.out / "runs"
    runs.mkdir(parents=True, exist_ok=True)
    videos, builds, says = {}, {}, {}
    for minutes in sorted(args.lengths):
        heights = [h for h in args.heights if run_name(minutes, h) not in args.skip]
        for height, pair in make_inputs(args.pool, args.work, minutes, heights).items():
            videos[minutes, height] = pair
    for minutes, height in sorted(videos):  # the short ones first: an error shows early
        name = run_name(minutes, height)
        if name in args.skip:
            continue
        done = runs / f"{name}.json"
        if not done.exists() or args.rerun:
            print(f"building {name} ...", file=sys.stderr, flush=True)
            build(name, *videos[minutes, height], args.work, runs)
        builds[minutes, height] = json.loads(done.read_text("utf-8"))
    for (_, height), r in sorted(builds.items()):
        done = runs / f"{r['name']}.say.json"
        if height in args.say_heights and "build" in r:
            if not done.exists() or args.rerun:
                print(f"say and dub with {r['name']} ...", file=sys.stderr, flush=True)
                clip = dub_clip(args.work, videos, height)
                say_and_dub(r["name"], args.work / "models" / r["name"], clip, runs)
            says[r["name"]] = json.loads(done.read_text("utf-8"))
    command = "python -m miketalk_lab.bench.hd_scaling " + " ".join(sys.argv[1:])
    tsv, markdown = tables(builds, says, command)
    (args.out / "hd_scaling.tsv").write_text(tsv, "utf-8")
    (args.out / "hd_scaling.md").write_text(markdown, "utf-8")
    return markdown


if __name__ == "__main__":
    sys.exit(main())
