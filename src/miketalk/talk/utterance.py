"""An utterance on disk: the mp4 and its timeline JSON written together, and read back."""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Sequence
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.lipsync.motion import JerkMeter, Motion, measure
from miketalk.lipsync.timeline import Timeline
from miketalk.media.atomic import atomic_paths, sweep_beside
from miketalk.media.ownership import file_record
from miketalk.media.video import write_mp4
from miketalk.model.face import Model
from miketalk.model.manifest import strict_json
from miketalk.speech.types import Phone, Utterance
from miketalk.talk.output import TIMELINE_FORMAT, check_output

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    import numpy as np

    from miketalk.composite.background import Background
    from miketalk.draw.registry import Drawing
    from miketalk.speech.acoustic import Recording

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Spoken:
    """What :func:`miketalk.talk.say.say` made.

    Attributes
    ----------
    timeline : Timeline
        The timeline of the mp4's frames.
    motion : Motion
        The measures of its motion.
    video, timeline_json : Path
        The two files written.
    words : tuple of str
        What was said (a synthesized text's normalized words; a recording's transcript).
    duration : float
        Seconds of sound in the mp4.
    lipsync_model : str
        The lip-sync model that drew the mouth.
    trajectory : str or None
        The trained face's trajectory model (None: another lip-sync model).
    utterance : Utterance or None
        Synthesized speech as spoken (lengthened if the paper's mode lengthened phones);
        None when a recording spoke.
    """

    timeline: Timeline
    motion: Motion
    video: Path
    timeline_json: Path
    words: tuple[str, ...]
    duration: float
    lipsync_model: str
    trajectory: str | None = None
    utterance: Utterance | None = None


def write_utterance(
    output: Path,
    *,
    model: Model,
    timeline: Timeline,
    samples: np.ndarray,
    rate: int,
    natural_duration: float,
    extra: dict,
    drawing: Drawing,
    recording: Recording | None = None,
    progress: bool = False,
    overwrite: bool = False,
    background: Background | None = None,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
    max_px_per_frame: float | None = None,
    sound: str | os.PathLike[str] | None = None,
) -> Motion:
    """Render ``timeline`` into the mp4 ``output`` with its sound, and its JSON beside it.

    The JSON is :meth:`Timeline.to_dict` plus ``format``, ``extra``,
    ``largest_step_px``, ``motion`` and ``mp4`` (the mp4's name, size and SHA-256: what
    tells a later run that miketalk wrote it, :mod:`miketalk.media.ownership`). The two
    files are published as one unit (:func:`miketalk.media.atomic.atomic_paths`: the old
    pair or the new, never one of each, and another process writing the same output
    waits); what killed runs left beside ``output`` is settled first, and the output is
    checked again, under its lock, just before it is replaced.

    Parameters
    ----------
    drawing : Drawing
        What draws the frames (:mod:`miketalk.draw.registry`): the paper's transitions,
        the learned coarticulation (the motion is then measured on its weights) or the
        trained face.
    recording : Recording, optional
        The recording of the speech the frames follow (``say --audio``, ``dub``): the
        trained face's ``heard`` trajectory listens to it. None for synthesized speech.
    background : Background, optional
        Frames of the person to composite each rendered mouth into
        (:func:`miketalk.composite.background.composited`); the video then has the
        background's size. None: the model's frames as they are (a still face).
    inputs : sequence of path-like
        What the utterance reads: never written over (:func:`check_output`).
    max_px_per_frame : float, optional
        The step limit the learned lip-sync keeps by blurring its path (the paper's is
        blurred in ``timeline`` already); None: no limit.
    sound : path-like, optional
        The recording whose sound the mp4 plays, at its own rate and channels
        (:func:`~miketalk.media.video.write_mp4`'s ``audio_file``); None: ``samples``.

    Returns
    -------
    Motion
        The measures of the utterance's motion.
    """
    output = check_output(output, overwrite=overwrite, inputs=inputs)
    sweep_beside(output)
    for t in timeline.transitions:  # every viseme must be in the model before we start
        model.displacement(t.source, t.target)
    started = time.perf_counter()
    compositing = region = None
    if background is not None:  # only the region compositing reads is drawn (and measured)
        from miketalk.composite.for_model import MouthCompositing

        compositing = MouthCompositing(model, background)
        region = compositing.region
    jerk = JerkMeter(region)
    rendered, weights, states = drawing.frames(
        model, timeline, recording=recording, max_px_per_frame=max_px_per_frame, region=region
    )
    frames = jerk.watch(rendered)
    if compositing is not None:
        frames = compositing.frames(frames, fps=timeline.fps, i420=True)
    if progress:
        from tqdm import tqdm

        frames = tqdm(frames, total=len(timeline.frames), desc="rendering", unit="frame")
    json_path = output.with_suffix(".json")

    def guard() -> None:  # what the output is now, under its lock, before it is replaced
        check_output(output, overwrite=overwrite, inputs=inputs)

    with (
        closing(rendered),
        atomic_paths([output, json_path], guard=guard) as (video_tmp, json_tmp),
    ):
        write_mp4(
            video_tmp, frames, fps=timeline.fps, audio=None if sound else samples, rate=rate,
            n_frames=len(timeline.frames), audio_file=sound,
        )  # fmt: skip
        motion = measure(
            timeline, model.displacement, natural_duration=natural_duration, jerk=jerk,
            weights=weights, own_frames=drawing.own_frames, states=states,
        )  # fmt: skip
        doc = (
            {"format": TIMELINE_FORMAT}
            | timeline.to_dict()
            | extra
            | {"largest_step_px": motion.largest_step_px, "motion": motion.to_dict()}
            | {"mp4": file_record(video_tmp) | {"name": output.name}}
        )
        try:
            text = json.dumps(doc, indent=1, allow_nan=False)
        except ValueError as err:
            raise MiketalkError(
                f"the timeline of {output} holds a value JSON cannot: {err}"
            ) from None
        json_tmp.write_text(text, encoding="utf-8")
    log.info(
        "rendered %d frames (%d morphs) and wrote %s in %.2f s",
        len(timeline.frames), motion.morphs, output, time.perf_counter() - started,
    )  # fmt: skip
    return motion


def own_frames_doc(drawing: Drawing) -> dict:
    """What the JSON of an utterance drawn with the person's own frames (the trained face)
    says of them: the trajectory, and that the step limit does not apply (its frames are not
    morphs between visemes, whose flows would measure a step)."""
    return {"trajectory": drawing.trajectory, "max_px_per_frame_applies": False}


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
        The phones at the engine's own timing, before the paper's mode
        lengthened any.
    planned_duration : float
        Seconds of audio the planned phones make.
    max_px_per_frame : float or None
        The limit ``say`` was given.
    sampling : str
        ``"blur"``, ``"paper"`` or ``"none"`` (``"paper"`` for a JSON from
        before sampling was recorded, ``"none"`` when there was no limit).
    max_slowdown : float or None
        The paper mode's cap on lengthening.
    lipsync_model : str
        ``"paper"``, ``"learned"`` or ``"trained"`` (``"paper"`` for a JSON from before it
        was recorded).
    """

    text: str
    timeline: Timeline
    planned_phones: tuple[Phone, ...]
    planned_duration: float
    max_px_per_frame: float | None
    sampling: str = "paper"
    max_slowdown: float | None = None
    lipsync_model: str = "paper"


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
        doc = strict_json(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MiketalkError(f"no timeline at {path}") from None
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise MiketalkError(f"cannot read the timeline {path}: {err}") from None
    if not isinstance(doc, dict):
        raise MiketalkError(f"{path} is not a timeline (not a JSON object)")
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
    max_px = doc.get("max_px_per_frame")
    return Said(
        text=doc["text"],
        timeline=timeline,
        planned_phones=planned,
        planned_duration=doc["planned_duration"],
        max_px_per_frame=max_px,
        sampling=doc.get("sampling", "paper" if max_px is not None else "none"),
        max_slowdown=doc.get("max_slowdown"),
        lipsync_model=doc.get("lipsync_model", "paper"),
    )
