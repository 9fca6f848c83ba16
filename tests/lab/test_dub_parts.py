"""Where a command's CPU goes (miketalk_lab.bench.dub_parts): each thread and each process
under this one counted in its part."""

from __future__ import annotations

import subprocess
import sys
import threading

from miketalk_lab.bench.dub_parts import Sampler, part_of


def _spin(stop: threading.Event) -> None:
    x = 0
    while not stop.is_set():
        x += 1


def test_the_parts_are_named_by_thread_and_by_process() -> None:
    assert part_of("thread", "MainThread") == "writer (main thread)"
    assert part_of("thread", "miketalk-render_1") == "drawing (render threads)"
    assert part_of("thread", "miketalk-dub") == part_of("thread", "miketalk-dub_2")
    assert part_of("process", "mt:place_guided") == part_of("process", "mt:_aligned")
    assert part_of("process", "mt:_second_half").startswith("tracking")
    x264 = part_of("process", "ffmpeg-linux-x8", "/x/ffmpeg -i pipe: -c:v libx264 out.mp4")
    assert x264.startswith("x264") and part_of("process", "ffmpeg-linux-x8", "ffmpeg -i a.mp4") == (
        "ffmpeg decoding"
    )


def test_a_busy_thread_and_a_busy_child_are_counted_in_their_parts() -> None:
    """A thread that spins and a child process that spins each get CPU in their own part;
    an idle thread next to them gets almost none."""
    stop = threading.Event()
    busy = threading.Thread(target=_spin, args=(stop,), name="miketalk-render_0")
    idle = threading.Thread(target=stop.wait, name="miketalk-dub")
    sampler = Sampler().start()
    busy.start()
    idle.start()
    subprocess.run([sys.executable, "-c", "import time; t = time.process_time()\n"
                    "while time.process_time() - t < 0.5: pass"], check=True)  # fmt: skip
    child_seen = dict(sampler.last)
    stop.set()
    busy.join()
    idle.join()
    parts = sampler.stop()
    drawing = parts["drawing (render threads)"]
    assert drawing > 0.05 and parts.get("producer (registration, placements, compositing)", 0) < (
        drawing / 2
    )
    spun = [cpu for key, (cpu, part) in sampler.last.items() if key[0] == "process"]
    assert spun and max(spun) > 0.1, child_seen
