"""An utterance on disk: what was written (:class:`Spoken`, :mod:`miketalk.talk.publish`
writes it), and its timeline JSON read back (:func:`read_said`)."""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.lipsync.motion import Motion
from miketalk.lipsync.timeline import Timeline
from miketalk.model.manifest import strict_json
from miketalk.speech.types import Phone, Utterance

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    from miketalk.draw.registry import Drawing

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
    video, timeline_json : Path or None
        The two files written (None and None: a fragmented MP4 on a pipe, no JSON).
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
    video: Path | None
    timeline_json: Path | None
    words: tuple[str, ...]
    duration: float
    lipsync_model: str
    trajectory: str | None = None
    utterance: Utterance | None = None


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
