"""Where a command's CPU goes, part by part: each thread of the process and each process
under it, read from ``/proc`` as it runs (Linux).

``python -m miketalk_lab.bench.dub_parts OUT.json -- dub VIDEO ...`` runs ``miketalk``'s
command line in this process with a sampler thread beside it. Every :data:`PERIOD` seconds
the sampler reads the CPU (user + system) of each of this process's threads and of every
process forked or started under it (``/proc/PID/task/TID/children``, followed down), and
keeps each one's last reading: the CPU a thread or child spends after its last reading (at
most a period's) is not seen, and is in ``unattributed``, the whole run's CPU (this process
and its waited-for children, ``resource.getrusage``) less the parts. Each is named by
:func:`part_of`: the dub's producer thread (registration, the mouth's placements,
compositing), the drawing's threads, the main thread (the writer: frames to x264's pipe),
the recording's alignment and the second half's tracking (forked children, ``mt:`` names),
x264 and the ffmpeg decoders. :mod:`miketalk_lab.bench.speed` reports them for the 720p
dub, first and again (``make bench``).
"""

from __future__ import annotations

import json
import os
import resource
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path

__all__ = ["PERIOD", "Sampler", "part_of", "parts_of_run"]

#: Seconds between two readings.
PERIOD = 0.05

_TICK = os.sysconf("SC_CLK_TCK")


def _cpu_and_name(stat_path: str) -> tuple[float, str] | None:
    """User + system seconds and the name (``comm``) in a ``/proc/.../stat`` file."""
    try:
        text = Path(stat_path).read_text()
    except OSError:
        return None
    close = text.rfind(")")
    fields = text[close + 2 :].split()
    return (int(fields[11]) + int(fields[12])) / _TICK, text[text.find("(") + 1 : close]


def _children(pid: int) -> list[int]:
    """The processes ``pid``'s threads started."""
    found: list[int] = []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return found
    for tid in tasks:
        try:
            found += [int(p) for p in Path(f"/proc/{pid}/task/{tid}/children").read_text().split()]
        except (OSError, ValueError):
            pass
    return found


def part_of(kind: str, name: str, command: str = "") -> str:
    """The part a thread (``kind`` "thread", its Python name) or a process under this one
    (``kind`` "process", its ``comm`` and command line) is counted in."""
    if kind == "thread":
        if name == "MainThread":
            return "writer (main thread)"
        if name.startswith(("miketalk-render", "miketalk-flows")):
            return "drawing (render threads)"
        if name.startswith("miketalk-dub"):
            return "producer (registration, placements, compositing)"
        if name == "parts-sampler":
            return "the sampler"
        return f"thread {name.split('_')[0]}"
    if name.startswith("mt:"):
        return {
            "mt:_aligned": "alignment (child)",
            "mt:place_phones": "alignment (child)",
            "mt:place_guided": "alignment (child)",
            "mt:_second_half": "tracking, second half (child)",
        }.get(name, f"child {name}")
    if "ffmpeg" in name or "ffmpeg" in command:
        return "x264 encoder (ffmpeg)" if "libx264" in command else "ffmpeg decoding"
    return f"process {name}"


class Sampler:
    """Reads the CPU of this process's threads and of the processes under it every
    :data:`PERIOD` seconds, in a thread of its own, until :meth:`stop`."""

    def __init__(self) -> None:
        self.last: dict[tuple, tuple[float, str]] = {}  # (kind, id) -> (cpu, part)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="parts-sampler", daemon=True)

    def start(self) -> Sampler:
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.is_set():
            self.read()
            self._stop.wait(PERIOD)

    def read(self) -> None:
        """One reading of every thread and process under this one."""
        me = os.getpid()
        names = {t.native_id: t.name for t in threading.enumerate()}
        for tid in os.listdir(f"/proc/{me}/task"):
            got = _cpu_and_name(f"/proc/{me}/task/{tid}/stat")
            if got is None:
                continue
            known = self.last.get(("thread", tid))
            name = names.get(int(tid))  # None as a thread starts or ends: its name kept
            part = part_of("thread", name or got[1]) if name or known is None else known[1]
            self.last[("thread", tid)] = (got[0], part)
        todo = _children(me)
        while todo:
            pid = todo.pop()
            todo += _children(pid)
            try:
                command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            named = _cpu_and_name(f"/proc/{pid}/stat")
            if named is None:
                continue
            part = part_of("process", named[1], command)
            try:
                tasks = os.listdir(f"/proc/{pid}/task")
            except OSError:
                continue
            for tid in tasks:  # each thread: a process's own total ends with it
                got = _cpu_and_name(f"/proc/{pid}/task/{tid}/stat")
                if got is not None:
                    self.last[("process", pid, tid)] = (got[0], part)

    def stop(self) -> dict[str, float]:
        """The CPU seconds of each part, read last."""
        self._stop.set()
        self._thread.join()
        self.read()
        parts: dict[str, float] = {}
        for cpu, part in self.last.values():
            parts[part] = parts.get(part, 0.0) + cpu
        return parts


def parts_of_run(argv: Sequence[str]) -> dict:
    """``miketalk`` ``argv`` run here under a :class:`Sampler`: each part's CPU seconds,
    the whole run's (``total``), what the parts miss (``unattributed``) and the wall."""
    from miketalk.cli.main import main as cli_main

    started, wall = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    sampler = Sampler().start()
    try:
        code = cli_main(list(argv))
    except SystemExit as exit_:
        code = exit_.code
    parts = sampler.stop()
    me, kids = (resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    total = (me.ru_utime - started.ru_utime + me.ru_stime - started.ru_stime
             + kids.ru_utime + kids.ru_stime)  # fmt: skip
    return {
        "exit": code, "wall": time.perf_counter() - wall, "total": total,
        "parts": dict(sorted(parts.items(), key=lambda kv: -kv[1])),
        "unattributed": total - sum(parts.values()),
    }  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m miketalk_lab.bench.dub_parts OUT.json -- MIKETALK_ARGS...``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) < 3 or args[1] != "--":
        print("usage: python -m miketalk_lab.bench.dub_parts OUT.json -- ARGS", file=sys.stderr)
        return 2
    found = parts_of_run(args[2:])
    Path(args[0]).write_text(json.dumps(found, indent=1), encoding="utf-8")
    return 0 if found["exit"] in (0, None) else 1


if __name__ == "__main__":
    sys.exit(main())
