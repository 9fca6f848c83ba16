"""Text in, talking-face video out: speech, lip-sync, morphing, mp4."""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.media.video import write_mp4
from miketalk.speech.backend import PendingSpeech, SpeechBackend, get_backend
from miketalk.speech.types import Phone, Utterance
from miketalk.talk.lipsync import Timeline, largest_step, speak_in_sync
from miketalk.talk.model import Model
from miketalk.visemes import VisemeTable, default_table

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    import numpy as np

DEFAULT_MODEL = defaults.model_dir()


def default_model_dir() -> Path:
    """``$MIKETALK_MODEL``, else :data:`DEFAULT_MODEL` here or in the source checkout."""
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
    fps: float = defaults.FPS,
    max_px_per_frame: float | None = defaults.MAX_PX_PER_FRAME,
    backend: SpeechBackend | None = None,
    table: VisemeTable | None = None,
    progress: bool = False,
) -> tuple[Utterance, Timeline]:
    """Speak ``text`` as an mp4 at ``output``, with its timeline JSON beside it.

    The video is written atomically: on any failure no mp4 (and no timeline)
    is left at ``output``. The JSON (``output`` with suffix ``.json``) is
    :meth:`Timeline.to_dict` plus ``text``, ``largest_step_px``,
    ``max_px_per_frame``, ``planned_phones`` (the phones the engine predicted
    before oversampling lengthened them) and ``planned_duration``;
    :func:`read_said` reads it back.

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
    planned: list[tuple[Phone, ...]] = []
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
            on_planned=planned.append,
        )
    planned_phones = planned[-1] if planned else utterance.phones
    write_utterance(
        output,
        model=model,
        timeline=timeline,
        samples=utterance.samples,
        rate=utterance.rate,
        extra={
            "text": utterance.text,
            "largest_step_px": largest_step(timeline, model.displacement),
            "max_px_per_frame": max_px_per_frame,
            "planned_phones": [asdict(p) for p in planned_phones],
            # the wav ends on the sample nearest the last phone's end (Utterance's invariant)
            "planned_duration": round(planned_phones[-1].end * utterance.rate) / utterance.rate,
        },
        progress=progress,
    )
    return utterance, timeline


def write_utterance(
    output: Path,
    *,
    model: Model,
    timeline: Timeline,
    samples: np.ndarray,
    rate: int,
    extra: dict,
    progress: bool = False,
) -> None:
    """Render ``timeline`` into the mp4 ``output`` with its sound, and its JSON beside it.

    The JSON is :meth:`Timeline.to_dict` plus ``extra``. Both files are written
    atomically; when the JSON cannot be written the new mp4 is removed, so no
    mp4 is left without its timeline.
    """
    for t in timeline.transitions:  # every viseme must be in the model before we start
        model.displacement(t.source, t.target)
    frames = model.render(timeline)
    if progress:
        from tqdm import tqdm

        frames = tqdm(frames, total=len(timeline.frames), desc="rendering", unit="frame")
    write_mp4(
        output, frames, fps=timeline.fps, audio=samples, rate=rate, n_frames=len(timeline.frames)
    )
    doc = timeline.to_dict() | extra
    try:
        write_text_atomic(output.with_suffix(".json"), json.dumps(doc, indent=1))
    except BaseException:
        output.unlink(missing_ok=True)
        raise


@dataclass(frozen=True)
class Said:
    """What :func:`say` wrote beside an mp4: enough to render its frames again and check them.

    Attributes
    ----------
    text : str
        The text as spoken.
    timeline : Timeline
        The timeline of the mp4's frames (``Model.render(timeline)`` made them).
    planned_phones : tuple of Phone
        The phones the engine predicted, before oversampling lengthened any.
    planned_duration : float
        Seconds of audio the predicted phones would have made.
    max_px_per_frame : float or None
        The oversampling limit ``say`` was given.
    """

    text: str
    timeline: Timeline
    planned_phones: tuple[Phone, ...]
    planned_duration: float
    max_px_per_frame: float | None


def read_said(path: str | os.PathLike[str]) -> Said:
    """Read the timeline JSON :func:`say` wrote (``<name>.json`` beside ``<name>.mp4``).

    Raises
    ------
    MiketalkError
        If the file is missing, is not JSON, or lacks a field (for example a
        JSON from before ``planned_phones`` was recorded: make the utterance again).
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise MiketalkError(f"no timeline at {path}") from None
    except (OSError, json.JSONDecodeError) as err:
        raise MiketalkError(f"cannot read the timeline {path}: {err}") from None
    missing = [k for k in ("text", "planned_phones", "planned_duration") if k not in doc]
    if missing:
        raise MiketalkError(f"{path} has no {', '.join(missing)}: make the utterance again")
    try:
        planned = tuple(Phone(**p) for p in doc["planned_phones"])
    except TypeError as err:
        raise MiketalkError(f"{path}: malformed planned_phones ({err})") from None
    try:
        timeline = Timeline.from_dict(doc)
    except MiketalkError as err:
        raise MiketalkError(f"{path}: {err}") from None
    return Said(
        text=doc["text"],
        timeline=timeline,
        planned_phones=planned,
        planned_duration=doc["planned_duration"],
        max_px_per_frame=doc.get("max_px_per_frame"),
    )
