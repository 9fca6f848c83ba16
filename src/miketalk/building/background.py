"""A model's background video, chosen from its corpus when the model is built.

:func:`write_background` keeps a few seconds of the reference clip (cut where the head
stands still) and what registers other video of the person, through
:func:`miketalk.model.background.save_background`.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from miketalk import defaults
from miketalk.composite.background import background_from_video, check_video
from miketalk.composite.loop import head_speed, still_window
from miketalk.model.background import save_background


def write_background(
    model_dir: str | os.PathLike[str],
    *,
    corpus_dir: str | os.PathLike[str],
    media: str,
    seconds: float = defaults.BACKGROUND_SECONDS,
    shortest: float = defaults.BACKGROUND_SHORTEST,
    segments: str | os.PathLike[str] | None = None,
) -> dict:
    """Keep ``shortest`` to ``seconds`` of the reference clip as the model's background.

    The frames kept (:func:`~miketalk.composite.background.still_window`) start and end where
    the head stands still, so the ping-pong loop turns unseen, and keep a blink when the
    clip has one. Written to ``background/``; ``background.json`` records which frames
    (``start``).

    Parameters
    ----------
    model_dir : path
        The model being built.
    corpus_dir : path
        Its corpus of clips (the reference, the face mask, the mouth box).
    media : str
        The clips' media pattern with ``{id}``, or the one video of a face whose
        clips are its utterances (``segments``).
    seconds, shortest : float
        The most and the least of the clip to keep.
    segments : path, optional
        A one-video face's ``segments.json``: where the reference clip starts in ``media``.

    Returns
    -------
    dict
        What ``background.json`` records.
    """
    from miketalk.corpus.clips import FACE_MASK as CORPUS_FACE
    from miketalk.corpus.clips import REFERENCE as CORPUS_REFERENCE
    from miketalk.corpus.clips import corpus_stabilizer, mouth_box
    from miketalk.media.images import read_image
    from miketalk.track.crop import crop_from_doc

    corpus_dir = Path(corpus_dir)
    regions = json.loads((corpus_dir / "regions.json").read_text(encoding="utf-8"))
    clip = regions["reference"]["clip"]
    crop = crop_from_doc(regions.get("crop"))
    stabilizer = corpus_stabilizer(corpus_dir)
    where, part = Path(media.replace("{id}", clip)), {}
    if crop is not None:  # a face crop's: the longest shot (any registers through its crops)
        clip, where, part = _longest_shot(corpus_dir)
    elif segments is not None:
        from miketalk.corpus.one_video import utterance_clip

        found = utterance_clip(segments, clip, media=media)
        where, part = found.media, {"start": found.start, "frames": found.span[1]}
    if crop is not None:
        from miketalk.composite.tracked import tracked_background

        whole = tracked_background(where, stabilizer, crop, source=f"clip {clip}", **part)
    else:
        frames, fps = check_video(where) if not part else _read_part(where, part)
        whole = background_from_video(frames, fps, stabilizer, source=f"clip {clip}")
    fps = whole.fps
    x, y, w, _h = stabilizer.mouth_box
    speed = head_speed(whole.transforms, (x + w / 2, y - 0.5 * w))  # the nose
    start, stop = still_window(
        speed, whole.blinks, shortest=max(2, round(shortest * fps)),
        longest=max(2, round(seconds * fps)), shot=whole.shot,
    )  # fmt: skip
    background = replace(
        whole, frames=whole.frames[start:stop], transforms=whole.transforms[start:stop],
        blinks=tuple(b - start for b in whole.blinks if start <= b < stop),
        shown=None if whole.shown is None else whole.shown[start:stop], shot=None,
    )  # fmt: skip
    face = read_image(corpus_dir / CORPUS_FACE)[..., 0] > 127
    return save_background(
        model_dir,
        background,
        reference=read_image(corpus_dir / CORPUS_REFERENCE),
        face=face,
        mouth_box=mouth_box(corpus_dir),
        clip=clip,
        start=start,
        crop=crop,
    )


def _longest_shot(corpus_dir: Path) -> tuple[str, Path, dict]:
    """The face-crop corpus's longest clip: its id, video and span in it."""
    import pandas as pd

    from miketalk.corpus.clips import SOURCES_TABLE

    table = pd.read_csv(corpus_dir / SOURCES_TABLE, sep="\t", keep_default_na=False)
    row = table.iloc[int(np.argmax(table["frames"].to_numpy()))]  # the first on a tie
    start = float(row["first_frame"]) / float(row["fps"])
    return str(row["clip"]), Path(row["media"]), {"start": start, "frames": int(row["frames"])}


def _read_part(media: Path, part: dict) -> tuple[np.ndarray, float]:
    """The frames of a part of a video (an utterance), as the corpus cut them."""
    from miketalk.media.decode import read_video

    return read_video(media, start=part["start"], frames=part["frames"])


__all__ = ["write_background"]
