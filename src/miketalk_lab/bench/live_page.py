"""Live Speak in a real browser: what the viewer sees, timed by the page itself.

``python -m miketalk_lab.bench.live_page OUT [--model LABEL=DIR ...] [--repeats N]
[--only first|long|stop ...]`` starts
``miketalk serve`` on a free port of 127.0.0.1 with the models (default: ``make run``'s
synthetic face and s1), drives Debian's Chromium (Playwright, headless; never ``playwright
install``) and measures, per model:

- **first frame**: Speak clicked to the first frame of the face on the screen (the page's own
  ``performance.now()`` at the click and at the video's first ``requestVideoFrameCallback``),
  a 10-word sentence, the median (min, max) of ``repeats`` runs (target: 0.5 s); and where
  that time goes: the click to the job's answer (``posted``) and to the stream's first bytes
  in the page (``first_byte``);
- **stalls**: a text of about two minutes of speech played to its end: how often, after its
  first frame, the video waited for data (``waiting`` events) and for how long in all
  (target: never);
- **Stop**: Stop clicked one second into the long text's playback, to the server's record of
  the job as ended (the page's clock), to the stream's work unwound (the server's own
  ``stopped_in``), and to the last ffmpeg and Festival of the server gone (this process
  watching ``/proc``) (target: 0.5 s).

It saves a screenshot of each model's live playback (``OUT/shots/LABEL-live.png``) and
``OUT/live_page.json``; the figures go into make bench's summary. Times depend on the load:
the load average is recorded with them.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import sys
import time

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk_lab.bench.page_timings import served_page, speak

REPEATS = 5
#: What is measured: the first frames, the long text's waits, the stops.
PARTS = frozenset({"first", "long", "stop"})
#: Ten words (the issue's say of 10 words).
SENTENCE = "Bin blue at F two now, please say it again soon."
#: About two minutes of speech (some 300 words), sentence by sentence.
LONG_TEXT = " ".join(
    [
        "Bin blue at F two now.",
        "Place red by G nine soon.",
        "Lay green with H four please.",
        "Set white in J six again.",
        "The face is drawn while the next sentence is spoken.",
        "Each phone shows its viseme in full at its middle, and the flow between two",
        "visemes carries every pixel of one to its place in the other.",
    ]
    * 5
)


def descendants(pid: int) -> dict[int, str]:
    """Every live process under ``pid`` with its command name."""
    found: dict[int, str] = {}
    todo = [pid]
    while todo:
        parent = todo.pop()
        for task in pathlib.Path(f"/proc/{parent}/task").glob("*"):
            try:
                children = (task / "children").read_text().split()
            except OSError:
                continue
            for child in map(int, children):
                try:
                    stat = pathlib.Path(f"/proc/{child}/stat").read_text()
                except OSError:
                    continue
                if stat.rsplit(")", 1)[1].split()[0] != "Z" and child not in found:
                    found[child] = stat.split("(", 1)[1].rsplit(")", 1)[0]
                    todo.append(child)
    return found


def _tools(pid: int) -> set[int]:
    return {p for p, name in descendants(pid).items() if name.startswith(("ffmpeg", "festival"))}


def _speak(page, label: str, text: str) -> None:
    speak(page, label, text, until="firstFrame", timeout_s=300)


def _seen(page) -> dict:
    return page.evaluate("Object.assign({}, document.getElementById('player').dataset)")


def _played_whole(page, timeout_s: float) -> dict:
    page.wait_for_selector("#player[data-live-ended]", state="attached", timeout=timeout_s * 1e3)
    page.wait_for_selector("#result[data-job]", state="attached", timeout=120_000)
    _until(page, "document.getElementById('player').ended", timeout_s)
    return _seen(page)


def _until(page, expression: str, timeout_s: float) -> None:
    """Wait until ``expression`` holds in the page (asked from here: the page's CSP forbids
    the evaluated strings of Playwright's own ``wait_for_function``)."""
    deadline = time.monotonic() + timeout_s
    while not page.evaluate(f"() => Boolean({expression})"):
        if time.monotonic() > deadline:
            raise MiketalkError(f"the page never had {expression} within {timeout_s:g} s")
        time.sleep(0.05)


def _spread(runs: list[float]) -> dict[str, float]:
    return {"median": round(statistics.median(runs), 3), "min": round(min(runs), 3),
            "max": round(max(runs), 3)}  # fmt: skip


def live_figures(
    models: dict[str, pathlib.Path], out_dir: pathlib.Path, *, repeats: int = REPEATS,
    parts: frozenset[str] = PARTS,
) -> dict[str, float]:  # fmt: skip
    """Measure the figures of ``parts`` (of :data:`PARTS`) for ``models`` (label -> model
    folder); see the module docstring."""
    for model in models.values():
        if not (model / "manifest.json").is_file():
            raise MiketalkError(f"no model at {model}: run `make run` first (make bench does)")
    shots = out_dir / "shots"
    shots.mkdir(parents=True, exist_ok=True)
    figures: dict[str, float] = {}
    with served_page(models, height=900) as (page, url, server):
        page.goto(url)
        page.wait_for_selector("body[data-ready='1']", timeout=60_000)
        for label, model in models.items():
            figures |= _one_model(page, label, model.name, server.pid, shots, repeats, parts)
    figures["load_average_1min"] = round(os.getloadavg()[0], 2)
    return figures


def _one_model(page, label: str, name: str, server_pid: int, shots: pathlib.Path,
               repeats: int, parts: frozenset[str]) -> dict[str, float]:  # fmt: skip
    figures: dict[str, float] = {}
    if "first" in parts:
        figures |= _first_frames(page, label, name, repeats)
    if "long" in parts:
        figures |= _long_text(page, label, name, shots)
    if "stop" in parts:
        figures |= _stops(page, label, name, server_pid, shots, repeats)
    return figures


def _first_frames(page, label: str, name: str, repeats: int) -> dict[str, float]:
    figures: dict[str, float] = {}
    marks: dict[str, list[float]] = {"posted": [], "first_byte": [], "first_frame": []}
    for _ in range(repeats):
        _speak(page, name, SENTENCE)
        seen = _seen(page)
        for mark, key in (("posted", "posted"), ("first_byte", "firstByte"),
                          ("first_frame", "firstFrame")):  # fmt: skip
            marks[mark].append(float(seen.get(key, "nan")))  # nan: a page without it
        _played_whole(page, 120)
    for mark, runs in marks.items():  # where the first frame's time goes
        for stat, value in _spread(runs).items():
            figures[f"live_{mark}_{stat}_seconds_{label}"] = value
    return figures


def _long_text(page, label: str, name: str, shots: pathlib.Path) -> dict[str, float]:
    """A long text played to its end: the viewer's waits."""
    figures: dict[str, float] = {}
    _speak(page, name, LONG_TEXT)
    figures[f"live_long_first_frame_seconds_{label}"] = float(_seen(page)["firstFrame"])
    page.wait_for_timeout(1500)
    page.locator("#result").screenshot(path=str(shots / f"{label}-live.png"))
    page.screenshot(path=str(shots / f"{label}-live-page.png"))
    seen = _played_whole(page, 900)
    figures[f"live_long_stalls_{label}"] = int(seen.get("stalls", 0))
    figures[f"live_long_stalled_seconds_{label}"] = float(seen.get("stalledSeconds", 0))
    figures[f"live_long_seconds_{label}"] = round(page.evaluate(
        "document.getElementById('player').duration"), 2)  # fmt: skip
    return figures


def _stops(page, label: str, name: str, server_pid: int, shots: pathlib.Path,
           repeats: int) -> dict[str, float]:  # fmt: skip
    """Stop one second into the long text."""
    figures: dict[str, float] = {}
    page_stop, server_stop, gone = [], [], []
    for _ in range(repeats):
        _speak(page, name, LONG_TEXT)
        page.wait_for_timeout(1000)
        working = _tools(server_pid)
        asked = time.perf_counter()
        page.click("#stop")
        while working & _tools(server_pid):
            time.sleep(0.005)
        gone.append(time.perf_counter() - asked)
        page.wait_for_selector("#player[data-stop-seconds]", state="attached", timeout=30_000)
        seen = _seen(page)
        page_stop.append(float(seen["stopSeconds"]))
        server_stop.append(float(seen.get("stoppedIn", "nan")))
    for what, runs in (("page", page_stop), ("work", server_stop), ("processes", gone)):
        for stat, value in _spread(runs).items():
            figures[f"live_stop_{what}_{stat}_seconds_{label}"] = value
    page.locator("#result").screenshot(path=str(shots / f"{label}-stopped.png"))
    return figures


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """make bench's entry: the synthetic face and s1 of ``make run``."""
    models = {"synthetic": defaults.model_dir("synthetic"), "s1": defaults.model_dir("s1")}
    return report(live_figures(models, out_dir), out_dir)


def report(
    figures: dict[str, float], out_dir: pathlib.Path, name: str = "live_page"
) -> dict[str, float]:
    """Print ``figures`` and write them to ``out_dir/NAME.json``; return them."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for figure, value in figures.items():
        print(f"{figure:52s} {value:8.3f}")
    (out_dir / f"{name}.json").write_text(json.dumps(figures, indent=1, sort_keys=True))
    return figures


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.live_page")
    parser.add_argument("out", type=pathlib.Path, nargs="?",
                        default=defaults.RESULTS / "bench" / "live_page")  # fmt: skip
    parser.add_argument(
        "--model",
        action="append",
        metavar="LABEL=DIR",
        help="a model to measure (default: make run's synthetic and s1)",
    )
    parser.add_argument("--repeats", type=int, default=REPEATS)
    parser.add_argument("--only", action="append", choices=sorted(PARTS),
                        help="measure only this part (repeatable; default: all)")  # fmt: skip
    args = parser.parse_args(argv)
    models = (
        dict(m.split("=", 1) for m in args.model)
        if args.model
        else {
            "synthetic": str(defaults.model_dir("synthetic")),
            "s1": str(defaults.model_dir("s1")),
        }
    )
    paths = {label: pathlib.Path(path) for label, path in models.items()}
    parts = frozenset(args.only) if args.only else PARTS
    report(live_figures(paths, args.out, repeats=args.repeats, parts=parts), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
