"""How fast miketalk answers: stops, refusals, a workflow with nothing to do, the page.

``python -m miketalk_lab.bench responsiveness`` (``make bench``, after ``make run``). The
tests hold the behaviour (a signal stops the work and every child, a refusal comes before
any work starts, the page plays what it was asked); the times live here, where a busy
machine does not fail a test and a regression still shows:

- **stops** (the promise: 2 s): SIGINT and SIGTERM sent to a worker pool waiting on its
  jobs, to ``miketalk say`` while it renders and encodes a long text, to ``say --audio``
  while it aligns 2.4 minutes of recording, to ``miketalk build`` while it decodes its
  video (six GRID clips joined), and SIGTERM to ``miketalk serve`` while a say of
  the page runs. Each is the wall time from the signal to the process's end, and the part
  of it the process waited for a core (its main thread's run-queue wait,
  ``/proc/PID/schedstat``): on a loaded machine that part is the machine's, not the program's.
- **refusals** (one line before any work): an output that is a folder, a word of 10,000
  letters, ``say -f /dev/zero``, ``build --workers 0``: the whole command's wall time.
- **workflow**: ``snakemake -n`` on the finished ``make run`` (nothing to be done).
- **the page** (headless Chromium against ``miketalk serve``): the page listed its models,
  ``/api/models`` answered, and Speak to playing, for the synthetic face and s1.

Each figure is the median of ``REPEATS`` runs.
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import imageio_ffmpeg

from miketalk import defaults
from miketalk.errors import MiketalkError

ROOT = pathlib.Path(__file__).resolve().parents[3]
GRID = ROOT / "data" / "grid_s1"
SYNTHETIC = defaults.model_dir("synthetic")
S1 = defaults.model_dir("s1")
REPEATS = 3
#: A text that takes the synthetic face some seconds to render.
LONG_TEXT = " ".join(
    ["MikeTalk morphs between visemes to make a face speak, one transition at a time."] * 12
)
SENTENCE = "Bin blue at F two now, please say it again soon."

#: Two workers asleep on 20 jobs of 120 s, the main thread waiting on them as the flows
#: stage does; the workers' pids on stdout once both run, "stopped" when a signal ends it
#: (``tests/product/test_safety.py`` runs the same script).
POOL_SCRIPT = """
import sys, time
from miketalk.console import handle_termination
from miketalk.workers import process_pool, results

def job(i):
    time.sleep(120)

if __name__ == "__main__":
    with handle_termination():
        try:
            with process_pool(2) as pool:
                futures = [pool.submit(job, i) for i in range(20)]
                while len(pool._processes) < 2:
                    time.sleep(0.05)
                print(" ".join(map(str, pool._processes)), flush=True)
                for _ in results(futures):  # as the flows stage waits (map_in_pool)
                    pass
        except KeyboardInterrupt:
            print("stopped", flush=True)
"""


def _queued_seconds(pid: int) -> float:
    """Seconds process ``pid``'s main thread has waited, ready to run, for a core."""
    try:
        return int(pathlib.Path(f"/proc/{pid}/schedstat").read_text().split()[1]) / 1e9
    except (OSError, IndexError, ValueError):
        return 0.0


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (the children of each of its threads, and theirs)."""
    out, todo = [], [pid]
    while todo:
        parent = todo.pop()
        children: list[int] = []
        for task in pathlib.Path(f"/proc/{parent}/task").glob("*"):
            try:
                children += map(int, (task / "children").read_text().split())
            except OSError:
                continue
        out += children
        todo += children
    return out


def _encoding(proc: subprocess.Popen) -> bool:
    """Whether ``proc`` has an ffmpeg child (its frames are being encoded)."""
    for child in _descendants(proc.pid):
        try:
            if "ffmpeg" in pathlib.Path(f"/proc/{child}/comm").read_text(errors="replace"):
                return True
        except OSError:
            pass
    return False


def _wait_for(condition: Callable[[], bool], proc: subprocess.Popen, what: str) -> None:
    deadline = time.monotonic() + 300
    while not condition():
        if proc.poll() is not None or time.monotonic() > deadline:
            raise MiketalkError(f"the bench's process never reached {what}")
        time.sleep(0.01)


def _stop_seconds(proc: subprocess.Popen, signum: int) -> tuple[float, float]:
    """Send ``signum``; the seconds to the process's end, and those it waited for a core."""
    queued = _queued_seconds(proc.pid)
    started = time.perf_counter()
    proc.send_signal(signum)
    last = queued
    while proc.poll() is None:
        last = max(last, _queued_seconds(proc.pid))
        if time.perf_counter() - started > 120:
            proc.kill()
            raise MiketalkError(f"{proc.args[:4]} did not stop within 120 s")
        time.sleep(0.002)
    return time.perf_counter() - started, last - queued


def _miketalk(*args: object) -> list[str]:
    return [sys.executable, "-m", "miketalk.cli", *map(str, args)]


def _stop_pool(tmp: pathlib.Path, signum: int) -> tuple[float, float]:
    proc = subprocess.Popen([sys.executable, "-c", POOL_SCRIPT], stdout=subprocess.PIPE, text=True)
    proc.stdout.readline()
    return _finish(proc, signum)


def _stop_say(tmp: pathlib.Path, signum: int) -> tuple[float, float]:
    out = tmp / f"say{signum}.mp4"
    proc = subprocess.Popen(_miketalk("say", LONG_TEXT, "-o", out, "--model", SYNTHETIC))
    _wait_for(lambda: _encoding(proc), proc, "its encoding")
    time.sleep(0.5)
    return _finish(proc, signum)


def _joined_recording(tmp: pathlib.Path) -> tuple[pathlib.Path, pathlib.Path]:
    """The committed GRID clips' sound joined (2.4 minutes) and its transcript's file."""
    lines = (GRID / "transcripts.txt").read_text().split("\n")
    names = [line.split(None, 1) for line in lines if line.strip()]
    (tmp / "list.txt").write_text(
        "".join(f"file '{GRID / 'video' / name}.mpg'\n" for name, _ in names)
    )
    wav = tmp / "joined.wav"
    subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-y", "-f", "concat", "-safe", "0",
         "-i", str(tmp / "list.txt"), "-vn", str(wav)],
        check=True,
    )  # fmt: skip
    text = tmp / "joined.txt"
    text.write_text(" ".join(words for _, words in names))
    return wav, text


def _stop_align(tmp: pathlib.Path, signum: int) -> tuple[float, float]:
    wav, text = _joined_recording(tmp)
    command = _miketalk("-v", "say", "--audio", wav, "-f", text, "-o", tmp / f"a{signum}.mp4",
                        "--model", S1)  # fmt: skip
    proc = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    for line in proc.stderr:
        if "aligning" in line:
            break
    time.sleep(1.0)  # inside the aligner
    return _finish(proc, signum)


def _stop_build(tmp: pathlib.Path, signum: int) -> tuple[float, float]:
    """A build of six joined GRID clips (18 s) stopped while its corpus stage decodes."""
    from miketalk_lab.bench.joined import join_clips

    joined = tmp / "joined"
    if not (joined / "transcript.txt").is_file():
        grid = str(GRID)
        clips = ["bbaf2n", "lgwg2n", "pric4p", "swih9a", "bbas3a", "srau3s"]
        media, timings = f"{grid}/video/{{id}}.mpg", f"{grid}/align/{{id}}.align"
        join_clips(
            clips, joined, media=media, transcripts=GRID / "transcripts.txt", timings=timings
        )
    video = joined / "joined.mp4"
    out = tmp / f"build{signum}"
    proc = subprocess.Popen(
        _miketalk("build", video, "--transcript", joined / "transcript.txt",
                  "-o", out, "--heldout-seconds", "0", "--quiet"),
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    _wait_for(lambda: _encoding(proc), proc, "its decoding")
    time.sleep(0.5)
    return _finish(proc, signum)


def _stop_serve(tmp: pathlib.Path, signum: int) -> tuple[float, float]:
    import http.client

    proc = subprocess.Popen(
        _miketalk("serve", "--port", "0", "--results", tmp / "jobs", "--models",
                  tmp / "models", "--model", SYNTHETIC),
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    address = proc.stdout.readline().split("http://")[1].split("/")[0]
    connection = http.client.HTTPConnection(address, timeout=60)
    body = json.dumps({"kind": "say", "model": SYNTHETIC.name, "text": LONG_TEXT})
    connection.request(
        "POST", "/api/jobs", body, {"X-Miketalk": "1", "Content-Type": "application/json"}
    )
    connection.getresponse().read()
    _wait_for(lambda: _encoding(proc), proc, "a say's encoding")
    time.sleep(0.5)
    return _finish(proc, signum)


def _finish(proc: subprocess.Popen, signum: int) -> tuple[float, float]:
    try:
        return _stop_seconds(proc, signum)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()


def _command_seconds(*args: object, cwd: pathlib.Path) -> float:
    started = time.perf_counter()
    proc = subprocess.run(_miketalk(*args), cwd=cwd, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    if proc.returncode != 2:
        raise MiketalkError(f"expected a refusal from {args}: {proc.stderr.strip()}")
    return seconds


def _refusals(tmp: pathlib.Path) -> dict[str, Callable[[], float]]:
    (tmp / "out.mp4").mkdir(exist_ok=True)
    return {
        "refuse_output_folder_seconds": lambda: _command_seconds(
            "say", "Hi.", "-o", "out.mp4", "--model", SYNTHETIC, cwd=tmp
        ),
        "refuse_long_word_seconds": lambda: _command_seconds(
            "say", "supercalifragilistic" * 500, "-o", "v.mp4", "--model", SYNTHETIC, cwd=tmp
        ),
        "refuse_endless_text_seconds": lambda: _command_seconds(
            "say", "-f", "/dev/zero", "-o", "v.mp4", "--model", SYNTHETIC, cwd=tmp
        ),
        "refuse_build_workers_seconds": lambda: _command_seconds(
            "build",
            GRID / "video" / "bbaf2n.mpg",
            "--transcript",
            GRID / "transcripts.txt",
            "-o",
            tmp / "m",
            "--workers",
            "0",
            cwd=tmp,
        ),
    }


def _workflow_dry_rerun_s() -> float:
    started = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "-n", "--cores", "1"], cwd=ROOT,
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    seconds = time.perf_counter() - started
    if "Nothing to be done" not in proc.stdout + proc.stderr:
        raise MiketalkError("the workflow has work to do: run `make run` first")
    return seconds


def _median(runs: list[float]) -> float:
    return round(statistics.median(runs), 3)


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """Measure every figure (medians of :data:`REPEATS` runs); print and return them."""
    from miketalk_lab.bench.page_timings import page_figures

    for model in (SYNTHETIC, S1):
        if not (model / "manifest.json").is_file():
            raise MiketalkError(f"no {model}: run `make run` first (make bench does)")
    out_dir.mkdir(parents=True, exist_ok=True)
    figures: dict[str, float] = {}
    stops = {
        "pool": _stop_pool, "say_render": _stop_say, "say_align": _stop_align,
        "build": _stop_build,
    }  # fmt: skip
    with tempfile.TemporaryDirectory() as scratch:
        tmp = pathlib.Path(scratch)
        for name, stop in [*stops.items(), ("serve_say", _stop_serve)]:
            signals = (signal.SIGTERM,) if name == "serve_say" else (signal.SIGINT, signal.SIGTERM)
            for signum in signals:
                runs = [stop(tmp, signum) for _ in range(REPEATS)]
                label = f"stop_{signal.Signals(signum).name.lower()}_{name}"
                figures[f"{label}_seconds"] = _median([took for took, _ in runs])
                figures[f"{label}_core_wait_seconds"] = _median([waited for _, waited in runs])
        for label, refusal in _refusals(tmp).items():
            figures[label] = _median([refusal() for _ in range(REPEATS)])
    figures["workflow_dry_rerun_seconds"] = _median(
        [_workflow_dry_rerun_s() for _ in range(REPEATS)]
    )
    figures |= page_figures({"synthetic": SYNTHETIC, "s1": S1}, SENTENCE, repeats=REPEATS)
    figures["load_average_1min"] = round(os.getloadavg()[0], 2)
    for name, value in figures.items():
        print(f"{name:45s} {value:8.3f}")
    (out_dir / "responsiveness.json").write_text(json.dumps(figures, indent=1, sort_keys=True))
    return figures


if __name__ == "__main__":
    run(
        pathlib.Path(
            sys.argv[1] if len(sys.argv) > 1 else defaults.RESULTS / "bench" / "responsiveness"
        )
    )
