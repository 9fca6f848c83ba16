"""How late a video's sound runs behind its mouth: the lag a model records, and its use.

A video cut and re-encoded on its way to the user (a downloaded address, a phone's
recording) may carry its sound a few frames after the picture: the weekly addresses (the
shared ``data/obama``) peak about 2 frames later, GRID's studio clips at 0. A model built
from such a video would learn its mouths from frames paired with sound that came later.

The product does not measure it. The measure (the lips' opening against the sound's
energy, frame by frame) marks dlib's 68 face landmarks, whose predictor was trained on
research-only data (iBUG 300-W), so it lives in the evaluation alone
(:mod:`miketalk_lab.evaluation.sound_sync`), which measures a video or a built model's
training utterances; ``tests/test_layout.py`` keeps that predictor out of the product.

What stays here reads and uses a lag a model records (``build/segments.json``:
:data:`KEY`): :func:`model_sound_lag`, and :func:`led`, a recording's mouth drawn that
much ahead of its sound (:mod:`miketalk.talk.recorded`); a segments file's lag is read
into its clips (:mod:`miketalk.corpus.clip_sources`). No build since the measure left the
product records one, and none before it recorded one other than 0 (:data:`APPLY` off), so
every model draws as built.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = ["APPLY", "KEY", "led", "model_sound_lag"]

#: Whether a lag measured is kept (:func:`miketalk_lab.evaluation.sound_sync.lag_of_curves`'s
#: ``seconds``; applied to a build and to a recording's mouth); off, it is measured in the
#: evaluation but the model is built and draws as before.
#: Off: on the weekly addresses held out (docs/anyone.md) the morph's and the learned
#: lip-sync's mouths already met his real opening best at 0 and -1 frames, and drawing them
#: the measured 52 ms ahead lowered their opening r on all four dubs tried (wa06 morph 0.46
#: to 0.16, learned 0.24 to -0.01; wa08 0.08 to 0.03, 0.20 to 0.06).
APPLY = False
#: Where a built model keeps the lag (``build/segments.json``'s key).
KEY = "sound_lag_s"


def model_sound_lag(model_dir: str | Path) -> float:
    """The lag a model records (``build/segments.json``'s :data:`KEY`), seconds; 0 for one
    that records none."""
    path = Path(model_dir) / "build" / "segments.json"
    if not path.is_file():
        return 0.0
    return float(json.loads(path.read_text("utf-8")).get(KEY, 0.0))


def led(
    phones: Sequence, samples: np.ndarray, rate: int, lead: float, duration: float
) -> tuple[list, np.ndarray]:
    """A recording's phones ``lead`` seconds earlier and its sound as much later (the first
    ``lead`` seconds dropped, silence after), for drawing a mouth that leads it; the phones
    still cover ``0 .. duration`` (the first from 0, the last to the end)."""
    from miketalk.speech.types import Phone

    if not lead:
        return list(phones), samples
    moved = [Phone(p.name, p.start - lead, p.end - lead) for p in phones if p.end - lead > 0]
    if not moved:
        return list(phones), samples
    moved[0] = Phone(moved[0].name, 0.0, moved[0].end)
    moved[-1] = Phone(moved[-1].name, moved[-1].start, max(duration, moved[-1].end))
    n = min(abs(round(lead * rate)), len(samples))
    silence = np.zeros(n, samples.dtype)
    if lead > 0:
        heard = np.concatenate([samples[n:], silence])
    else:
        heard = np.concatenate([silence, samples[: len(samples) - n]])
    return moved, heard
