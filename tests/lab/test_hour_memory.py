"""The hour's memory bench (miketalk_lab.bench.hour_memory): its text, its sampler, its plot."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

from miketalk.serve.config import MAX_TEXT_CHARS, MAX_TEXT_WORDS
from miketalk_lab.bench.hour_memory import Sampler, hour_text, plot


def test_the_hour_is_one_the_page_takes_and_the_same_each_time() -> None:
    text = hour_text(60)
    words = re.findall(r"[A-Za-z0-9']+", text)
    assert 9_000 <= len(words) <= MAX_TEXT_WORDS and len(text) <= MAX_TEXT_CHARS
    assert text == hour_text(60) != hour_text(60, seed=1)
    assert all(len(s.split()) == 6 for s in re.split(r"(?<=\.)\s+", text) if s)


def test_the_sampler_sums_the_memory_of_the_processes_under_its_own() -> None:
    """A child holding 80 MB is counted in the tree's sum, not in its parent's."""
    child = "b = b'x' * 80_000_000; import time; time.sleep(2)"
    parent = subprocess.Popen(
        [
            sys.executable,
            "-c",
            f"import subprocess, sys; subprocess.run([sys.executable, '-c', {child!r}])",
        ]
    )
    sampler = Sampler(parent.pid, lambda: 0)
    parent.wait(timeout=60)
    time.sleep(0.1)
    sampler.stop()
    tree = max(r[2] for r in sampler.rows)
    main = max(r[3] for r in sampler.rows)
    assert tree - main > 75 and main < 60
    assert max(sampler.names.values()) > 75


def test_the_plot_draws_every_run(tmp_path: Path) -> None:
    runs = {
        label: {"frames": 300, "speech_seconds": 10.0, "peak_tree_mb": peak,
                "samples": [(t, 30 * t, peak * t / 10, 1.0, 1.0) for t in range(11)]}
        for label, peak in (("a-pipe", 400.0), ("a-page", 900.0))
    }  # fmt: skip
    plot(runs, tmp_path / "memory.png")
    from PIL import Image

    image = Image.open(tmp_path / "memory.png").convert("RGB")
    colours = {image.getpixel((x, y)) for x in range(0, 900, 3) for y in range(0, 500, 3)}
    assert (31, 119, 180) in colours and (214, 39, 40) in colours
