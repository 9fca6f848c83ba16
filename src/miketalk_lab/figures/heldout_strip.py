"""A strip of a held-out side-by-side video: its columns as rows, around the mouth, over time.

The held-out videos (:func:`miketalk_lab.evaluation.heldout.heldout_stage`) put the
real clip and its re-syntheses side by side, one column each. The strip cuts
the mouth region out of every column at evenly spaced frames of the speech
and lays them out with one row per column (real, paper, learned, trained, trained_heard), each tile
labelled with its frame and the phone spoken then, so a reader compares the
mouths at the same instant down a column of the strip.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import Timeline
from miketalk.media.decode import read_video
from miketalk.media.images import write_png
from miketalk.media.sheets import grid
from miketalk_lab.evaluation.heldout import speech_frames

Path_ = str | os.PathLike[str]


def _phone_at(phones: Sequence[dict], t: float) -> str:
    for phone in phones:
        if phone["start"] <= t < phone["end"]:
            return phone["name"]
    return "-"


def heldout_strip(
    video: Path_,
    timeline_json: Path_,
    out: Path_,
    *,
    mouth_box: tuple[int, int, int, int],
    show: Sequence[str] | None = None,
    count: int = 10,
    scale: float = 1.5,
) -> np.ndarray:
    """Write the strip of a side-by-side video as a PNG; return it (RGB).

    Parameters
    ----------
    video : path-like
        The side-by-side mp4: columns of equal width.
    timeline_json : path-like
        Its timeline: ``fps``, the ``phones`` (which label each tile) and the
        names of the video's ``columns``, left to right.
    out : path-like
        The PNG to write.
    mouth_box : (x, y, w, h)
        The mouth region in one column's coordinates.
    show : sequence of str, optional
        The columns shown, one row each (default: every column but a
        ``difference``).
    count : int
        Frames shown, evenly spaced over the speech
        (:func:`miketalk_lab.evaluation.heldout.speech_frames`).
    scale : float
        Tiles are enlarged by this factor.

    Raises
    ------
    MiketalkError
        A timeline without ``columns``, a column to show that the video does
        not have, or a video that cannot be read.
    """
    frames, _ = read_video(video)
    with open(timeline_json, encoding="utf-8") as f:
        said = json.load(f)
    fps, phones, columns = said["fps"], said["phones"], said.get("columns")
    if not columns:
        raise MiketalkError(f"{timeline_json} does not name the video's columns")
    show = [c for c in columns if c != "difference"] if show is None else list(show)
    unknown = [name for name in show if name not in columns]
    if unknown:
        raise MiketalkError(f"{video} has no columns {unknown} (its columns: {columns})")
    speech = speech_frames(Timeline.from_dict(said))
    first, stop = (speech.start, speech.stop) if speech.stop > speech.start else (0, len(frames))
    picks = np.clip(np.linspace(first, stop - 1, count).round().astype(int), 0, len(frames) - 1)
    x, y, w, h = mouth_box
    width = frames.shape[2] // len(columns)
    tiles, labels = [], []
    for name in show:
        left = columns.index(name) * width + x
        for k in picks:
            tiles.append(frames[k, y : y + h, left : left + w])
            label = f"{name} {k}" if k == picks[0] else f"{k}"
            labels.append(f"{label} /{_phone_at(phones, (k + 0.5) / fps)}/")
    sheet = grid(tiles, labels, cols=len(picks), scale=scale)
    write_png(out, sheet)
    return sheet
