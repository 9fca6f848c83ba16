"""Text in, talking-face video out: speech, lip-sync, morphing, mp4."""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.media.video import write_mp4
from miketalk.speech.backend import PendingSpeech, SpeechBackend, get_backend
from miketalk.speech.types import Utterance
from miketalk.talk.lipsync import Timeline, largest_step, speak_in_sync
from miketalk.talk.model import Model
from miketalk.visemes import VisemeTable, default_table

DEFAULT_MODEL = Path("results/model/synthetic")


def default_model_dir() -> Path:
    """``$MIKETALK_MODEL``, else ``results/model/default`` here or in the source checkout."""
    if env := os.environ.get("MIKETALK_MODEL"):
        return Path(env)
    here = DEFAULT_MODEL
    if here.exists():
        return here
    checkout = Path(__file__).resolve().parents[2] / DEFAULT_MODEL
    return checkout if checkout.exists() else here


def open_model(directory: str | os.PathLike[str] | None, **options: object) -> Model:
    """Open a model, with a hint on how to build the default one when it is missing."""
    path = Path(directory) if directory is not None else default_model_dir()
    if not (path / "manifest.json").exists():
        hint = (
            "build the default model with `make run` (or `snakemake --cores all model`)"
            if directory is None
            else "pass --model with a directory built by the workflow"
        )
        raise MiketalkError(f"no model at {path}: {hint}")
    return Model(path, **options)


def say(
    text: str | PendingSpeech,
    output: str | os.PathLike[str],
    *,
    model: Model,
    fps: float = 30.0,
    max_px_per_frame: float | None = 2.5,
    backend: SpeechBackend | None = None,
    table: VisemeTable | None = None,
    progress: bool = False,
) -> tuple[Utterance, Timeline]:
    """Speak ``text`` as an mp4 at ``output``, with its timeline JSON beside it.

    The video is written atomically: on any failure no mp4 (and no timeline)
    is left at ``output``.

    Parameters
    ----------
    text : str or PendingSpeech
        The text, or its synthesis already started with ``backend.start(text)``
        (the engine then analyses the text while the caller loads the model;
        ``say`` finishes or closes it).
    output : path-like
        The ``.mp4`` to write.
    model : Model
        The visemes and their flows.
    fps : float
        Frame rate.
    max_px_per_frame : float or None
        Oversampling limit (None: no oversampling).
    backend : SpeechBackend, optional
        The engine for a ``str`` text (default Festival).
    table : VisemeTable, optional
        Phone-to-viseme table (default: the paper's).
    progress : bool
        Draw a progress bar on stderr.

    Returns
    -------
    (Utterance, Timeline)
        The audio actually used (re-synthesized if oversampling lengthened
        phones) and the timeline of the frames.
    """
    if isinstance(text, PendingSpeech):
        speech = text
    else:
        speech = (backend or get_backend("festival")).start(text)
    with speech:
        output = Path(output)
        if output.suffix.lower() != ".mp4":
            raise MiketalkError(f"output must be an .mp4 file, not {output.name!r}")
        utterance, timeline = speak_in_sync(
            speech,
            table or default_table(),
            fps=fps,
            displacement=model.displacement,
            max_px_per_frame=max_px_per_frame,
        )
    for t in timeline.transitions:  # every viseme must be in the model before we start
        model.displacement(t.source, t.target)
    frames = model.render(timeline)
    if progress:
        frames = _progress(frames, len(timeline.frames))
    write_mp4(output, frames, fps, utterance.samples, utterance.rate, n_frames=len(timeline.frames))
    doc = timeline.to_dict()
    doc["text"] = utterance.text
    doc["largest_step_px"] = largest_step(timeline, model.displacement)
    doc["max_px_per_frame"] = max_px_per_frame
    try:
        write_text_atomic(output.with_suffix(".json"), json.dumps(doc, indent=1))
    except BaseException:
        output.unlink(missing_ok=True)
        raise
    return utterance, timeline


def _progress(frames: Iterator[np.ndarray], total: int) -> Iterator[np.ndarray]:
    """Pass frames through, drawing a progress bar on stderr."""
    start = time.monotonic()
    width = 30
    for i, frame in enumerate(frames, 1):
        yield frame
        if i == total or i % 10 == 0:
            done = int(width * i / total)
            rate = i / max(time.monotonic() - start, 1e-9)
            sys.stderr.write(
                f"\rrendering [{'#' * done}{'.' * (width - done)}] {i}/{total} frames "
                f"({rate:.0f}/s)"
            )
            sys.stderr.flush()
    sys.stderr.write("\n")
