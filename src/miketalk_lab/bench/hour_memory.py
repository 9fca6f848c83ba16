"""An hour of text streamed: the peak memory of ``say -o -`` and of the page, and its course.

``python -m miketalk_lab.bench.hour_memory OUT --model LABEL=DIR [...] [--minutes 60]
[--only pipe|page ...]`` speaks a text of about ``--minutes`` of speech (GRID's grammar,
:func:`hour_text`: 9,600 words for an hour) two ways per model, and samples every
:data:`PERIOD` seconds the resident memory of every process of the work, summed (the
``VmRSS`` of each in ``/proc``: what the issue's target of 1.5 GB bounds; pages two
processes share are counted twice, so the sum is an upper bound):

- **pipe**: ``miketalk say -f TEXT --model DIR -o -``, its fragmented MP4 read as it comes by
  ``ffmpeg -c copy -f null`` (which counts the frames; it is the reader, not the work, and
  its memory is not counted): the tree of ``say`` (Python, Festival, its ffmpeg);
- **page**: ``miketalk serve`` with the model, a live Speak of the text by the page's own
  HTTP calls (``POST /api/jobs`` with ``live``, then ``GET /api/jobs/<id>/live``, read as it
  comes into the same counting ffmpeg, then the job polled to its end: the server writes
  the whole ``say.mp4``, its timeline and its cues): the tree of the server. A client
  reading as fast as it comes is what the server's memory depends on: the server writes the
  stream to the job's file whatever its readers do (:mod:`miketalk.serve.live`), so a
  browser playing it in real time would take the hour and measure nothing more of the
  server (the page drops what it played 30 s ago from its own buffer).

Writes ``OUT/hour_memory.json`` (per model and way: the peak of the sum, the peak of the
main process alone, the frames read, the speech's length, the wall time, and the memory at
each quarter of the frames read: whether it grows with the text), ``OUT/LABEL-WAY.tsv`` (the
samples: seconds, frames read so far, the sum, the main process, and the sum of the
processes' proportional shares, ``Pss``: shared pages counted once, in MB) and
``OUT/memory.png`` (every run's memory against the speech read so far). ``run(out_dir)``
(``make bench``) measures s1 of ``make run`` both ways on a text of :data:`BENCH_MINUTES`.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import pathlib
import random
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk_lab.bench.live_page import descendants

#: Seconds between two samples of the processes' memory.
PERIOD = 0.5
#: Words of the text per minute of speech (Festival's default voice on GRID's sentences:
#: 9,758 words made 56.4 minutes).
WORDS_PER_MINUTE = 160
#: The text's length in ``make bench`` (minutes of speech).
BENCH_MINUTES = 15
#: The ways an hour is streamed.
WAYS = ("pipe", "page")

_COMMANDS = ("bin", "lay", "place", "set")
_COLOURS = ("blue", "green", "red", "white")
_PREPOSITIONS = ("at", "by", "in", "with")
_LETTERS = tuple("ABCDEFGHIJKLMNOPQRSTUVXYZ")  # GRID has no W
_DIGITS = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine")
_ADVERBS = ("again", "now", "please", "soon")


def hour_text(minutes: float = 60, *, seed: int = 0) -> str:
    """About ``minutes`` of speech in GRID's six-word sentences ("Bin blue at F two now."),
    drawn at random from its grammar with ``seed`` (the same text each time)."""
    pick = random.Random(seed).choice
    sentences = [
        f"{pick(_COMMANDS).capitalize()} {pick(_COLOURS)} {pick(_PREPOSITIONS)} "
        f"{pick(_LETTERS)} {pick(_DIGITS)} {pick(_ADVERBS)}."
        for _ in range(max(1, round(minutes * WORDS_PER_MINUTE / 6)))
    ]
    # a paragraph of ten sentences a line: Festival reads it as a person would
    return "\n".join(" ".join(sentences[i : i + 10]) for i in range(0, len(sentences), 10))


def rss_mb(pid: int) -> tuple[float, float]:
    """The resident memory of ``pid`` in MB, and its proportional share (``Pss``: a page
    it shares with ``n`` processes counted ``1/n``); 0 once it is gone."""
    try:
        lines = pathlib.Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines()
    except OSError:
        return 0.0, 0.0
    found = {line.split(":")[0]: int(line.split()[1]) / 1024 for line in lines
             if line.startswith(("Rss:", "Pss:"))}  # fmt: skip
    return found.get("Rss", 0.0), found.get("Pss", 0.0)


@dataclass
class Sampler:
    """Samples, every :data:`PERIOD` s in a thread of its own, the memory of ``pid`` and of
    every process under it, and ``progress()`` (frames read so far)."""

    pid: int
    progress: Callable[[], int]
    rows: list[tuple[float, int, float, float, float]] = field(default_factory=list)
    names: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._stop = threading.Event()
        self._start = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="sampler", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            own, shared = rss_mb(self.pid)
            total = own
            for child, name in descendants(self.pid).items():
                mb, pss = rss_mb(child)
                total, shared = total + mb, shared + pss
                self.names[name] = max(self.names.get(name, 0.0), mb)
            t = time.monotonic() - self._start
            self.rows.append(
                (round(t, 2), self.progress(), round(total, 1), round(own, 1), round(shared, 1))
            )
            if self._stop.wait(PERIOD):
                return

    def stop(self) -> None:
        """Stop sampling (after one last sample)."""
        self._stop.set()
        self._thread.join()


class FrameCounter:
    """``ffmpeg -c copy -f null`` reading a fragmented MP4 on its stdin as it comes: the
    frames it has read so far (:attr:`frames`) and its speech's length (:attr:`seconds`)."""

    def __init__(self, stdin: int | None = None) -> None:
        import imageio_ffmpeg

        self.frames = 0
        self.seconds = 0.0
        self.proc = subprocess.Popen(
            [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostats", "-loglevel", "error",
             "-i", "pipe:0", "-map", "0", "-c", "copy", "-f", "null", "-",
             "-progress", "pipe:1", "-stats_period", "0.5"],
            stdin=stdin if stdin is not None else subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )  # fmt: skip
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            key, _, value = line.decode(errors="replace").strip().partition("=")
            if key == "frame" and value.isdigit():
                self.frames = int(value)
            elif key == "out_time_us" and value.lstrip("-").isdigit():
                self.seconds = max(self.seconds, int(value) / 1e6)

    def finish(self) -> str:
        """Wait for the end of its input; ffmpeg's complaints (empty when it read it all)."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        err = self.proc.stderr.read().decode(errors="replace")
        self.proc.wait()
        self._thread.join()
        return err.strip() if self.proc.returncode else ""


def _miketalk(*args: str) -> list[str]:
    return [sys.executable, "-m", "miketalk.cli", *args]


def _environment(tmp: pathlib.Path) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("MIKETALK_MODEL", None)
    env["MIKETALK_RESULTS"] = str(tmp / "none")  # the server lists the given model alone
    return env


def run_pipe(model: pathlib.Path, text_file: pathlib.Path, tmp: pathlib.Path) -> dict:
    """``say -f TEXT -o -`` read as it comes; its tree's memory."""
    read, write = os.pipe()
    counter = FrameCounter(stdin=read)
    os.close(read)
    started = time.monotonic()
    say = subprocess.Popen(
        _miketalk("say", "-f", str(text_file), "--model", str(model), "-o", "-"),
        stdout=write, stderr=subprocess.PIPE, text=True, env=_environment(tmp),
    )  # fmt: skip
    os.close(write)
    sampler = Sampler(say.pid, lambda: counter.frames)
    err = say.stderr.read()
    code = say.wait()
    sampler.stop()
    wall = time.monotonic() - started
    problem = counter.finish()
    if code != 0 or problem:
        raise MiketalkError(f"say -o - ended with status {code}: {(err or problem)[-400:]}")
    return _figures(sampler, counter, wall)


def _request(address: str, method: str, path: str, body: dict | None = None):
    conn = http.client.HTTPConnection(address, timeout=600)
    headers = {"X-Miketalk": "1", "Host": address, "Origin": f"http://{address}"}
    data = None
    if body is not None:
        data = json.dumps(body).encode()
        headers["Content-Type"] = "application/json"
    conn.request(method, path, body=data, headers=headers)
    return conn, conn.getresponse()


def _json(address: str, method: str, path: str, body: dict | None = None) -> dict:
    conn, answer = _request(address, method, path, body)
    try:
        doc = json.loads(answer.read() or b"null")
    finally:
        conn.close()
    if answer.status >= 400:
        raise MiketalkError(f"{method} {path}: {answer.status} {doc}")
    return doc


def run_page(model: pathlib.Path, text: str, tmp: pathlib.Path) -> dict:
    """A live Speak of ``text`` by the page's HTTP calls; the server's tree's memory."""
    server = subprocess.Popen(
        _miketalk("serve", "--port", "0", "--results", str(tmp / "jobs"), "--models",
                  str(tmp / "models"), "--model", str(model)),
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=_environment(tmp),
    )  # fmt: skip
    counter = FrameCounter()
    sampler = Sampler(server.pid, lambda: counter.frames)
    try:
        address = server.stdout.readline().split("http://")[1].split("/")[0]
        faces = _json(address, "GET", "/api/models")
        face = next((m for m in faces if m["label"] == model.name), faces[0])
        started = time.monotonic()
        job = _json(address, "POST", "/api/jobs",
                    {"kind": "say", "model": face["id"], "text": text, "live": True})  # fmt: skip
        conn, answer = _request(address, "GET", job["live"])
        try:
            while block := answer.read1(1 << 16):
                counter.proc.stdin.write(block)
        finally:
            conn.close()
        problem = counter.finish()
        while (doc := _json(address, "GET", f"/api/jobs/{job['id']}"))["status"] not in (
            "done",
            "failed",
            "cancelled",
            "interrupted",
        ):
            time.sleep(0.5)
        wall = time.monotonic() - started
        time.sleep(2 * PERIOD)  # the memory once the job has ended
        if doc["status"] != "done" or problem:
            raise MiketalkError(f"the live job ended {doc['status']}: {doc['message']} {problem}")
        figures = _figures(sampler, counter, wall)
        figures["job_frames"] = doc["result"]["frames"]
        return figures
    finally:
        sampler.stop()
        server.terminate()
        server.communicate(timeout=60)
        if counter.proc.poll() is None:
            counter.proc.kill()


def _figures(sampler: Sampler, counter: FrameCounter, wall: float) -> dict:
    rows = sampler.rows
    frames = max(counter.frames, 1)
    quarters = []
    for q in (1, 2, 3, 4):  # the peak of the sum within each quarter of the frames read
        inside = [r[2] for r in rows if (q - 1) * frames / 4 < r[1] <= q * frames / 4]
        quarters.append(max(inside) if inside else None)
    return {
        "peak_tree_mb": max(r[2] for r in rows),
        "peak_main_mb": max(r[3] for r in rows),
        "peak_tree_pss_mb": max(r[4] for r in rows),
        "peak_by_process_mb": {k: round(v, 1) for k, v in sorted(sampler.names.items())},
        "quarters_tree_mb": quarters,
        "frames": counter.frames,
        "speech_seconds": round(counter.seconds, 1),
        "wall_seconds": round(wall, 1),
        "samples": rows,
    }


def plot(runs: dict[str, dict], path: pathlib.Path, *, size: tuple[int, int] = (900, 500)) -> None:
    """Each run's summed memory against the minutes of speech read so far, as a PNG."""
    from PIL import Image, ImageDraw

    width, height = size
    left, bottom, top, right = 70, 40, 20, 20
    colours = [(31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14)]
    fps = {k: r["frames"] / max(r["speech_seconds"], 1e-9) for k, r in runs.items()}
    x_max = max(max(r[1] for r in run["samples"]) / fps[k] / 60 for k, run in runs.items())
    y_max = max(1600.0, max(run["peak_tree_mb"] for run in runs.values()) * 1.1)
    image = Image.new("RGB", size, "white")
    draw = ImageDraw.Draw(image)

    def at(x: float, y: float) -> tuple[float, float]:
        return (left + x / max(x_max, 1e-9) * (width - left - right),
                height - bottom - y / y_max * (height - bottom - top))  # fmt: skip

    for mb in range(0, int(y_max) + 1, 250):
        draw.line([at(0, mb), at(x_max, mb)], fill=(225, 225, 225))
        draw.text((5, at(0, mb)[1] - 6), f"{mb} MB", fill="black")
    draw.line([at(0, 1536), at(x_max, 1536)], fill=(255, 0, 0))
    draw.text((at(x_max, 1536)[0] - 90, at(0, 1536)[1] - 14), "1.5 GB target", fill=(255, 0, 0))
    step = max(1, round(x_max / 10))
    for minute in range(0, int(x_max) + 1, step):
        draw.text((at(minute, 0)[0] - 5, height - bottom + 8), f"{minute}", fill="black")
    draw.text((width // 2 - 120, height - 18), "minutes of speech read", fill="black")
    for n, (label, run) in enumerate(runs.items()):
        colour = colours[n % len(colours)]
        points = [at(r[1] / fps[label] / 60, r[2]) for r in run["samples"]]
        draw.line(points, fill=colour, width=2)
        draw.text((left + 10, top + 14 * n), f"{label}: peak {run['peak_tree_mb']:.0f} MB",
                  fill=colour)  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    image.save(path)


def hour_figures(
    models: dict[str, pathlib.Path], out_dir: pathlib.Path, *, minutes: float = 60,
    ways: tuple[str, ...] = WAYS,
) -> dict[str, dict]:  # fmt: skip
    """Each model spoken each way; the runs' figures, written to ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    text = hour_text(minutes)
    runs: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as scratch:
        tmp = pathlib.Path(scratch)
        text_file = tmp / "hour.txt"
        text_file.write_text(text + "\n")
        for label, model in models.items():
            for way in ways:
                name = f"{label}-{way}"
                print(f"{time.strftime('%H:%M:%S')} {name} ...", file=sys.stderr, flush=True)
                load = os.getloadavg()[0]
                if way == "pipe":
                    run = run_pipe(model, text_file, tmp)
                else:
                    run = run_page(model, text, tmp)
                run["load_start"], run["load_end"] = round(load, 1), round(os.getloadavg()[0], 1)
                runs[name] = run
                rows = ["seconds\tframes\ttree_mb\tmain_mb\ttree_pss_mb"]
                rows += ["\t".join(map(str, r)) for r in run["samples"]]
                write_text_atomic(out_dir / f"{name}.tsv", "\n".join(rows) + "\n")
                print(f"{name}: {_line(run)}", file=sys.stderr, flush=True)
    kept = {k: {f: v for f, v in r.items() if f != "samples"} for k, r in runs.items()}
    doc = {"words": len(text.split()), "minutes_asked": minutes, "runs": kept}
    write_text_atomic(out_dir / "hour_memory.json", json.dumps(doc, indent=1))
    plot(runs, out_dir / "memory.png")
    return runs


def _line(run: dict) -> str:
    quarters = ", ".join("-" if q is None else f"{q:.0f}" for q in run["quarters_tree_mb"])
    return (
        f"peak {run['peak_tree_mb']:.0f} MB (main {run['peak_main_mb']:.0f}, the tree's "
        f"proportional share {run['peak_tree_pss_mb']:.0f}); by quarter "
        f"{quarters}; {run['frames']} frames, {run['speech_seconds'] / 60:.1f} min of speech "
        f"in {run['wall_seconds']:.0f} s, load {run['load_start']}-{run['load_end']}"
    )


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """make bench's entry: s1 of ``make run``, both ways, :data:`BENCH_MINUTES` of speech."""
    runs = hour_figures({"s1": defaults.model_dir("s1")}, out_dir, minutes=BENCH_MINUTES)
    figures: dict[str, float] = {}
    for name, r in runs.items():
        key = name.replace("-", "_")
        figures[f"hour_memory_{key}_peak_mb"] = r["peak_tree_mb"]
        first, last = r["quarters_tree_mb"][0], r["quarters_tree_mb"][-1]
        if first is not None and last is not None:
            figures[f"hour_memory_{key}_growth_mb"] = round(last - first, 1)
    return figures


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.hour_memory")
    parser.add_argument("out", type=pathlib.Path)
    parser.add_argument("--model", action="append", default=[], metavar="LABEL=DIR")
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--only", action="append", choices=WAYS, default=[])
    args = parser.parse_args(argv)
    models = {}
    for item in args.model or [f"s1={defaults.model_dir('s1')}"]:
        label, _, folder = item.partition("=")
        if not folder:
            parser.error(f"--model takes LABEL=DIR, not {item!r}")
        models[label] = pathlib.Path(folder)
    try:
        runs = hour_figures(models, args.out, minutes=args.minutes,
                            ways=tuple(args.only) or WAYS)  # fmt: skip
    except MiketalkError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    for name, r in runs.items():
        print(f"{name}: {_line(r)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
