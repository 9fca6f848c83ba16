"""Reading back what :func:`miketalk.talk.say.say` wrote beside an mp4: its timeline JSON."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from miketalk.errors import MiketalkError
from miketalk.speech.types import Phone
from miketalk.talk.lipsync import Timeline
from miketalk.talk.model import strict_json

__all__ = ["Said", "read_said"]


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
        ``"paper"`` or ``"learned"`` (``"paper"`` for a JSON from before it
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
