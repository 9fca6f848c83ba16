"""Stop: how long a stopped stream takes to end all its work, from the library and the CLI.

``python -m miketalk_lab.bench.stop [OUT] [--model DIR] [--repeats N]`` speaks a long text
(:data:`~miketalk_lab.bench.live_page.LONG_TEXT`, about two minutes, sentence by sentence)
with the model (default: ``make run``'s s1) and stops it once its fragmented MP4 has started
to come (:data:`STARTED_BYTES` read), ``repeats`` times each way:

- **cancel**: :func:`miketalk.api.say_stream` read by :func:`miketalk.api.write_fragmented`
  on a pipe; :meth:`Stream.cancel <miketalk.api.Stream.cancel>` from the reading thread, to
  every process under this one gone (Festival, ffmpeg) and the stream's producer unwound;
- **signal**: ``miketalk say -f TEXT -o - --model DIR`` read on a pipe; SIGINT (odd runs
  SIGTERM) to the command, to the command and every process it had started gone.

The target (issue 51): a stop ends playback and all work within 0.5 s. It writes
``OUT/stop.json`` with the median, min and max of each and the load average; times depend
on the load.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk_lab.bench.live_page import LONG_TEXT, descendants, report

REPEATS = 5
#: Bytes of the fragmented MP4 read before the stop: the face is playing by then.
STARTED_BYTES = 200_000
#: The issue's bound on a stop (s).
TARGET_S = 0.5
_TIMEOUT = 300.0  # seconds a run may take to start its stream or to end after a stop


def _read(fd: int, size: int) -> None:
    """Read ``size`` bytes from ``fd`` (the stream has started by then)."""
    got, deadline = 0, time.monotonic() + _TIMEOUT
    while got < size:
        block = os.read(fd, 1 << 16)
        if not block:
            raise MiketalkError(f"the stream ended after {got} bytes, before {size}")
        got += len(block)
        if time.monotonic() > deadline:
            raise MiketalkError(f"the stream gave {got} bytes in {_TIMEOUT:g} s")


def _drain(fd: int) -> None:
    """Read what is left on ``fd`` without waiting (a writer killed leaves no reader hung)."""
    os.set_blocking(fd, False)
    try:
        while os.read(fd, 1 << 16):
            pass
    except BlockingIOError:
        pass


def _until_gone(pids: set[int], started: float, *also) -> float:
    """Seconds from ``started`` until none of ``pids`` is alive and each of ``also()`` holds."""
    while set(descendants(os.getpid())) & pids or not all(f() for f in also):
        if time.perf_counter() - started > _TIMEOUT:
            raise MiketalkError(f"the work was still running {_TIMEOUT:g} s after the stop")
        time.sleep(0.002)
    return time.perf_counter() - started


def cancel_once(model: pathlib.Path, text: str) -> tuple[float, set[str]]:
    """One library stop: ``(seconds, names of the processes that were running)``."""
    from miketalk import api

    stream = api.say_stream(text, api.SaySettings(model=str(model)))
    read_end, write_end = os.pipe()

    def write() -> None:
        try:
            api.write_fragmented(stream, write_end)
        except (api.Cancelled, BrokenPipeError):
            pass

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    try:
        _read(read_end, STARTED_BYTES)
        running = descendants(os.getpid())
        started = time.perf_counter()
        stream.cancel()
        seconds = _until_gone(set(running), started, lambda: stream.wait(0))
        writer.join(_TIMEOUT)
    finally:
        os.close(write_end)
        _drain(read_end)
        os.close(read_end)
    return seconds, set(running.values())


def signal_once(model: pathlib.Path, text_file: pathlib.Path, sig: int) -> tuple[float, int]:
    """One stop of ``miketalk say -o -`` by ``sig``: ``(seconds, its exit status)``."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        # started by a shell without job control (nohup, `&` in a script): an ignored
        # Ctrl-C stays ignored across exec, so say would be given it as a terminal never does
        signal.signal(signal.SIGINT, signal.default_int_handler)
    command = [sys.executable, "-m", "miketalk.cli", "say", "-f", str(text_file), "-o", "-",
               "--model", str(model)]  # fmt: skip
    say = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    try:
        _read(say.stdout.fileno(), STARTED_BYTES)
        tree = {say.pid, *descendants(say.pid)}
        asked = time.perf_counter()
        say.send_signal(sig)
        while say.poll() is None or set(descendants(os.getpid())) & tree:
            if time.perf_counter() - asked > _TIMEOUT:
                raise MiketalkError(f"say was still running {_TIMEOUT:g} s after {sig}")
            _drain(say.stdout.fileno())
            time.sleep(0.002)
        return time.perf_counter() - asked, say.returncode
    finally:
        if say.poll() is None:
            say.kill()
            say.wait()
        say.stdout.close()


def _spread(runs: list[float]) -> dict[str, float]:
    return {"median": round(statistics.median(runs), 3), "min": round(min(runs), 3),
            "max": round(max(runs), 3)}  # fmt: skip


def stop_figures(model: pathlib.Path, *, repeats: int = REPEATS) -> dict[str, float]:
    """Every figure of the module docstring for ``model``."""
    if not (model / "manifest.json").is_file():
        raise MiketalkError(f"no model at {model}: run `make run` first (make bench does)")
    figures: dict[str, float] = {"load_average_1min_before": round(os.getloadavg()[0], 2)}
    cancels, killed = [], set()
    for _ in range(repeats):
        seconds, names = cancel_once(model, LONG_TEXT)
        cancels.append(seconds)
        killed |= names
    if not all(any(n.startswith(tool) for n in killed) for tool in ("festival", "ffmpeg")):
        raise MiketalkError(f"the stops found {sorted(killed)} running, not Festival and ffmpeg")
    with tempfile.TemporaryDirectory(prefix="miketalk-stop-") as tmp:
        text_file = pathlib.Path(tmp) / "long.txt"
        text_file.write_text(LONG_TEXT, encoding="utf-8")
        signals = []
        for i in range(repeats):
            sig = signal.SIGINT if i % 2 == 0 else signal.SIGTERM
            seconds, code = signal_once(model, text_file, sig)
            if code == 0:
                raise MiketalkError(f"say -o - ended with status 0 after {sig.name}")
            signals.append(seconds)
    for what, runs in (("cancel", cancels), ("signal", signals)):
        for stat, value in _spread(runs).items():
            figures[f"stop_{what}_{stat}_seconds"] = value
    figures["stop_target_seconds"] = TARGET_S
    figures["load_average_1min_after"] = round(os.getloadavg()[0], 2)
    return figures


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """make bench's entry: s1 of ``make run``."""
    return report(stop_figures(defaults.model_dir("s1")), out_dir, "stop")


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.bench.stop")
    parser.add_argument("out", type=pathlib.Path, nargs="?",
                        default=defaults.RESULTS / "bench" / "stop")  # fmt: skip
    parser.add_argument("--model", type=pathlib.Path, default=None, help="default: s1")
    parser.add_argument("--repeats", type=int, default=REPEATS)
    args = parser.parse_args(argv)
    model = args.model or defaults.model_dir("s1")
    report(stop_figures(model, repeats=args.repeats), args.out, "stop")
    return 0


if __name__ == "__main__":
    sys.exit(main())
