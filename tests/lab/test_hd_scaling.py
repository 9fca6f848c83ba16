"""The time-and-memory bench's pure parts (miketalk_lab.bench.hd_scaling): the upscale filter,
``/usr/bin/time``'s line, the sizes, a process tree's memory, and the tables from fake runs."""

from __future__ import annotations

import os
import subprocess
import sys

from miketalk_lab.bench import hd_scaling as hd


def test_scale_filter_keeps_the_aspect_and_pads_to_the_frame():
    assert hd.scale_filter(288) is None
    assert hd.scale_filter(720) == "scale=-2:720,pad=1280:720:(ow-iw)/2:0"
    assert hd.scale_filter(1080) == "scale=-2:1080,pad=1920:1080:(ow-iw)/2:0"
    assert hd.run_name(10, 720) == "10min_720p"


def test_time_file_sizes_and_durations():
    # GNU time writes "Command exited with non-zero status N" before the format on failure
    assert hd.parse_time_file(
        "Command exited with non-zero status 2\n593.2 5872640 500.5 20.5\n"
    ) == (
        593.2,
        5735.0,
        521.0,
    )
    assert hd.human_size(int(1.8 * 2**30)) == "1.8G"
    assert hd.human_size(304 * 2**20) == "304M"
    assert hd.human_size(512) == "512B"
    assert hd.minutes_seconds(593) == "9m53s"
    assert hd.minutes_seconds(235.4) == "3m55s"


def test_tree_memory_counts_the_children():
    child = subprocess.Popen(
        [sys.executable, "-c", "b = bytearray(64 << 20); import time; time.sleep(3)"]
    )
    try:
        import time

        deadline = time.monotonic() + 2.5
        rss = 0.0
        while rss < 60 and time.monotonic() < deadline:
            rss, pss = hd._tree_memory(os.getpid())
            time.sleep(0.1)
        assert rss >= 60, rss  # the child's 64 MB, found under this process
        assert 0 < pss <= rss + 1
    finally:
        child.kill()
        child.wait()


def _run(name, wall, peak, **extra):
    return {
        "name": name, "wall_s": wall, "cpu_s": 2 * wall, "peak_mb": peak, "tree_pss_mb": peak + 100,
        "tree_rss_mb": peak + 200, "load_start": 2.0, "load_mean": 3.0, "commit": "abc1234",
    } | extra  # fmt: skip


def test_tables_from_fake_runs():
    built = {
        "stage_seconds": {"segment": 10.0, "corpus": 50.0},
        "stage_peak_mb": {"segment": 300, "corpus": 900},
    }
    builds = {
        (2, 288): _run("2min_288p", 200.0, 900.0, build=built, model_bytes=300 << 20),
        (2, 720): _run("2min_720p", 260.0, 1000.0, build=built, model_bytes=2 << 30),
        (2, 1080): _run("2min_1080p", 700.0, 1200.0, error="error: out of memory"),
    }
    warm = _run("w", 20.0, 800.0) | {
        "calls": {"say_s": [2.5, 2.0], "open_s": 1.0, "background_s": 0.5, "peak_mb": 700}
    }
    cold0, cold1, dub = _run("c", 6.0, 900.0), _run("c", 5.0, 900.0), _run("d", 15.0, 1500.0)
    says = {"2min_720p": {"warm": warm, "cold0": cold0, "cold1": cold1, "dub": dub, "commit": "x"}}
    tsv, md = hd.tables(builds, says, "python -m miketalk_lab.bench.hd_scaling")
    rows = [line.split("\t") for line in tsv.splitlines()]
    assert rows[0][:3] == ["kind", "run", "wall_s"]
    assert [r[1] for r in rows[1:4]] == ["2min_288p", "2min_720p", "2min_1080p"]
    assert len(rows) == 1 + 3 + 4 and {len(r) for r in rows} == {len(rows[0])}
    assert "| 1280x720 | 2 min | 4m20s | 8m40s | 1000 | 1100 | 900 | 2.0G | 2.0 / 3.0 |" in md
    assert "failed: error: out of memory" in md
    assert "720p / 288p build time: 1.30x (target <= 1.5x: met; CPU time 1.30x)" in md
    assert "| 2min_720p | 2.50 / 2.00 | 1.00 + 0.50 | 700 | 6.0 / 5.0 | 15.0 | 1500 / 1600 |" in md


def test_the_sentences_have_ten_words():
    assert len(hd.SENTENCES) >= 2  # the cold says take the first two (an empty tuple: all() holds)
    assert all(len(s.split()) == 10 for s in hd.SENTENCES)
    assert len(set(hd.SENTENCES)) == len(hd.SENTENCES)
