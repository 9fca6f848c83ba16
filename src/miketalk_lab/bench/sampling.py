"""Benchmark of the sampling modes: natural-speed blur against the paper's lengthening.

``run(out_dir)`` runs ``miketalk say`` as a user does (a fresh process, the
default ``max_px_per_frame``, ``--json``) on the default model (``make run``
builds it) in each mode of :data:`MODES`, for the sentences of the project's
``config.yaml`` and for a text of about 300 words (:data:`TEXT_300`), and
reads back the measures of the motion ``say`` reports
(:class:`miketalk.lipsync.motion.Motion`): the duration of the speech over its
natural duration, the largest step between consecutive morphs, the largest
motion from one frame to the next, and the mean and largest jerk of the frames.

The issue's targets: in the default mode (blur) the speech lasts within
:data:`TARGET_DURATION` of its natural duration on every text, and its largest
step is no larger than the paper mode's. ``say`` of a 10-word sentence in at
most a second, warm, is timed by :mod:`miketalk_lab.bench.pipeline`.

Writes ``sampling.csv`` (a row per text and mode) to ``out_dir``.
"""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys
import tempfile
import time

import pandas as pd
import yaml

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import Sampling

DEFAULT_MODEL = defaults.model_dir("synthetic")
#: The project's configuration, whose ``sentences`` are measured.
CONFIG = pathlib.Path("config.yaml")
#: The modes compared; the first is ``say``'s default.
MODES = (Sampling.BLUR.value, Sampling.PAPER.value)
#: The default mode's target: the speech's duration within this fraction of its own.
TARGET_DURATION = 0.10
#: How much larger than the paper mode's blur's largest step may be and count as no
#: larger, pixels.
STEP_SLACK_PX = 0.01
#: Plain English prose of about 300 words (311), for the long-text measures.
TEXT_300 = (
    "Every morning the old ferry leaves the harbour a few minutes after seven. The "
    "captain is a quiet woman who has made the same crossing for nearly thirty years, and "
    "she still checks the ropes herself before anyone is allowed on board. Most of the "
    "passengers are people on their way to work: nurses going to the hospital on the far "
    "shore, a baker with flour on his sleeves, students who try to finish their homework "
    "on their knees. In summer there are tourists as well, and they stand at the rail "
    "with their cameras, waiting for the moment when the town behind them turns into a "
    "row of small coloured houses.\n\n"
    "The crossing takes about forty minutes when the sea is calm. On windy days it takes "
    "longer, and the boat rolls from side to side so that cups slide across the tables in "
    "the cafe. Children love those days. Their parents do not. The crew hand out blankets "
    "and tell stories about storms that were much worse, which does not help as much as "
    "they seem to think.\n\n"
    "Halfway across, the ferry passes a small island with a lighthouse and a single tree. "
    "Nobody has lived there for a long time, but every spring someone paints the door of "
    "the lighthouse a bright new blue. People on the boat like to guess who it might be. "
    "Some say it is the captain herself. She only smiles and looks at the water.\n\n"
    "When the ferry arrives, the passengers hurry down the ramp and disappear into the "
    "streets of the other town. The captain drinks a cup of tea, writes a few lines in "
    "her log book, and waits for the people who will make the journey back. It is not an "
    "exciting life, she says, but it is a good one, and the sea is never quite the same "
    "twice."
)

#: The measures of ``say``'s motion reported per text and mode.
MEASURES = ("duration_ratio", "largest_step_px", "largest_frame_motion_px", "mean_jerk",
            "largest_jerk")  # fmt: skip


def texts(config: pathlib.Path = CONFIG) -> dict[str, str]:
    """The sentences of ``config`` (name: text) and ``text300``: :data:`TEXT_300`."""
    try:
        sentences = yaml.safe_load(config.read_text(encoding="utf-8"))["sentences"]
    except (OSError, KeyError, TypeError) as err:
        raise MiketalkError(f"no sentences in {config}: {err}") from None
    return {**sentences, "text300": TEXT_300}


def say_motion(text: str, out: pathlib.Path, *, sampling: str, model: pathlib.Path) -> dict:
    """Run ``miketalk say --json`` on ``text`` in one mode; its ``motion`` and wall time."""
    source = out.with_suffix(".txt")
    source.write_text(text, encoding="utf-8")
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "miketalk.cli", "say", "--file", str(source), "-o", str(out),
         "--model", str(model), "--sampling", sampling, "--json"],
        capture_output=True, text=True,
    )  # fmt: skip
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        raise MiketalkError(f"miketalk say --sampling {sampling} failed: {proc.stderr.strip()}")
    return json.loads(proc.stdout)["motion"] | {"say_seconds": seconds}


def measure_modes(model: pathlib.Path = DEFAULT_MODEL) -> pd.DataFrame:
    """A row per text of :func:`texts` and mode of :data:`MODES`: the motion of its mp4."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in texts().items():
            for sampling in MODES:
                motion = say_motion(text, pathlib.Path(tmp) / f"{name}-{sampling}.mp4",
                                    sampling=sampling, model=model)  # fmt: skip
                rows.append({"text": name, "words": len(text.split()), "sampling": sampling}
                            | motion)  # fmt: skip
    return pd.DataFrame(rows)


def targets(table: pd.DataFrame) -> dict[str, float]:
    """The issue's targets on :func:`measure_modes`'s table (1.0 met, 0.0 not).

    ``blur_duration_within_10pct``: every text's blur duration ratio within
    :data:`TARGET_DURATION` of 1. ``blur_step_le_paper``: on every text,
    blur's largest step at most the paper mode's, up to :data:`STEP_SLACK_PX`
    (both modes keep it under the same limit, and meet it to a thousandth of a
    pixel); ``blur_step_minus_paper_px``: the largest difference, to show how
    close.
    """
    by = table.set_index(["text", "sampling"])
    names = list(dict.fromkeys(table["text"]))
    ratio = [by.loc[(n, "blur"), "duration_ratio"] for n in names]
    excess = [
        by.loc[(n, "blur"), "largest_step_px"] - by.loc[(n, "paper"), "largest_step_px"]
        for n in names
    ]
    return {
        "blur_duration_within_10pct": float(all(abs(r - 1) <= TARGET_DURATION for r in ratio)),
        "blur_step_le_paper": float(max(excess) <= STEP_SLACK_PX),
        "blur_step_minus_paper_px": float(max(excess)),
    }


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """Measure both modes on every text; write ``sampling.csv``; print and return the figures."""
    if not (DEFAULT_MODEL / "manifest.json").exists():
        raise MiketalkError("no default model: run `make run` first (make bench does)")
    out_dir.mkdir(parents=True, exist_ok=True)
    table = measure_modes()
    columns = ["text", "words", "sampling", "natural_duration", "duration", *MEASURES,
               "frames", "morphs", "say_seconds"]  # fmt: skip
    table = table[columns]
    (out_dir / "sampling.csv").write_text(table.to_csv(index=False, float_format="%.4f"))
    figures: dict[str, float] = {}
    for row in table.itertuples(index=False):
        for measure in (*MEASURES, "say_seconds"):
            figures[f"{row.text}_{row.sampling}_{measure}"] = float(getattr(row, measure))
    figures |= targets(table)
    for name, value in figures.items():
        print(f"{name:45s} {value:8.3f}")
    return figures


if __name__ == "__main__":
    run(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else defaults.RESULTS / "bench" / "sampling"))
