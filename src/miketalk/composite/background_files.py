"""A model's background sequence on disk: ``<model>/background/``.

``NNNN.png`` (the frames as recorded), ``field.npy`` (the clip's conform
field, empty when none), ``steady.png`` (the median of the frames stabilized
onto the reference: their light), ``reference.png`` and ``face_mask.png``
(what registers other video of the person, with the mouth box), and
``background.json`` (frame rate, frames, blinks, the mouth box, each frame's
transform), written last: the folder is complete once it exists.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator
from dataclasses import replace
from enum import StrEnum
from pathlib import Path

import numpy as np

from miketalk import defaults
from miketalk.composite.background import Background, background_from_video, check_video, composited
from miketalk.composite.loop import head_speed, still_window
from miketalk.errors import MiketalkError
from miketalk.track.crop import FaceCropSettings, crop_doc, crop_from_doc

__all__ = [
    "composite_renders",
    "has_background",
    "model_compositor",
    "model_crop",
    "model_stabilizer",
    "mouth_box_of",
    "read_background",
    "resolve_background",
    "save_background",
    "video_background",
    "write_background",
]

DIRECTORY = "background"
META = "background.json"
FIELD = "field.npy"
REFERENCE = "reference.png"
FACE_MASK = "face_mask.png"
STEADY = "steady.png"


def model_stabilizer(model_dir: str | os.PathLike[str]):
    """A :class:`~miketalk.stabilize.Stabilizer` for the model's person.

    Raises
    ------
    MiketalkError
        If the model keeps no background (it was not built from clips of a person).
    """
    from miketalk.media.images import read_image
    from miketalk.stabilize import Stabilizer

    where = Path(model_dir) / DIRECTORY
    if not (where / META).is_file():
        raise MiketalkError(
            f"the model {model_dir} was not built from video of a person (it has no "
            f"{DIRECTORY}/{META}): only such a model can play over a video"
        )
    meta = json.loads((where / META).read_text(encoding="utf-8"))
    crop = crop_from_doc(meta.get("crop"))
    if crop is not None:
        from miketalk.corpus.clips import crop_stabilizer

        return crop_stabilizer(read_image(where / REFERENCE), crop)
    face = read_image(where / FACE_MASK)[..., 0] > 127
    return Stabilizer.from_reference(
        read_image(where / REFERENCE), face=face, mouth_box=tuple(meta["mouth_box"])
    )


def model_compositor(
    model_dir: str | os.PathLike[str],
    size: tuple[int, int],
    *,
    skin: bool = defaults.BLEND_SKIN,
    **settings,
):
    """The :class:`~miketalk.composite.compositor.Compositor` of a model built from clips.

    Its blend mask about the model's mouth box, kept off the reference's backdrop and
    clothes (:func:`~miketalk.composite.compositor.skin_weight` of the reference and its
    face mask, unless ``skin=False``); ``settings`` go to the compositor. A face crop's mask
    is also held inside its jaw ellipse (:func:`~miketalk.track.crop.jaw_mask`), and its jaw's
    warp as :data:`miketalk.defaults.BLEND_FOLLOW_CROP` says (``follow_within`` or ``follow``
    given in ``settings`` win).
    """
    from miketalk.composite.compositor import Compositor, skin_weight
    from miketalk.media.images import read_image

    where = Path(model_dir) / DIRECTORY
    keep = None
    if skin:
        face = read_image(where / FACE_MASK)[..., 0] > 127
        keep = skin_weight(read_image(where / REFERENCE), face)
    crop = model_crop(model_dir)
    if crop is not None:  # a face crop's: inside the jaw (the frames' jaws turn elsewhere)
        from miketalk.track.crop import jaw_mask

        keep = jaw_mask(crop) if keep is None else keep * jaw_mask(crop)
        if defaults.BLEND_FOLLOW_CROP == "face":  # the jaw's warp off the room beside the jaw
            settings.setdefault("follow_within", keep)
        elif defaults.BLEND_FOLLOW_CROP == "off":
            settings.setdefault("follow", False)
    return Compositor(mouth_box_of(model_dir), size, keep=keep, **settings)


def mouth_box_of(model_dir: str | os.PathLike[str]) -> tuple[int, int, int, int]:
    """The mouth box ``(x, y, w, h)`` of the model's reference."""
    meta = json.loads((Path(model_dir) / DIRECTORY / META).read_text(encoding="utf-8"))
    return tuple(int(v) for v in meta["mouth_box"])


def has_background(model_dir: str | os.PathLike[str]) -> bool:
    """Whether the model keeps a background sequence (built from clips of a person)."""
    return (Path(model_dir) / DIRECTORY / META).is_file()


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


def save_background(
    model_dir: str | os.PathLike[str],
    background: Background,
    *,
    reference: np.ndarray,
    face: np.ndarray,
    mouth_box: tuple[int, int, int, int],
    clip: str,
    start: int = 0,
    crop: FaceCropSettings | None = None,
) -> dict:
    """Write ``background`` and what registers video to the reference into ``model_dir``.

    Parameters
    ----------
    model_dir : path
        The model.
    background : Background
        The frames, their transforms, field, blinks and light.
    reference, face : numpy.ndarray
        The reference frame (H, W, 3) and its face mask (H, W) bool.
    mouth_box : tuple of int
        ``(x, y, w, h)`` in the reference.
    clip : str
        Where the frames come from.
    start : int
        The clip's frame the first kept frame is.
    crop : FaceCropSettings, optional
        The face crop the model works in (its reference and mouth box are in crop
        pixels, the frames at the video's resolution); None: the frames' own pixels.

    Returns
    -------
    dict
        What ``background.json`` records.
    """
    from miketalk.media.atomic import atomic_path, write_text_atomic
    from miketalk.media.images import write_png

    out = Path(model_dir) / DIRECTORY
    out.mkdir(parents=True, exist_ok=True)
    for i, frame in enumerate(background.frames):
        write_png(out / f"{i:04d}.png", frame)
    with atomic_path(out / FIELD) as tmp, tmp.open("wb") as fh:
        np.save(fh, np.zeros((0,), np.float32) if background.field is None else background.field)
    write_png(out / STEADY, background.steady)
    write_png(out / REFERENCE, reference)
    write_png(out / FACE_MASK, np.where(face, 255, 0).astype(np.uint8))
    meta = {
        "clip": clip,
        "start": int(start),
        "fps": background.fps,
        "frames": len(background),
        "blinks": list(background.blinks),
        "mouth_box": [int(v) for v in mouth_box],
        "transforms": [[round(float(v), 6) for v in t.ravel()] for t in background.transforms],
    }
    if crop is not None:
        meta["crop"] = crop_doc(crop)
    if background.shown is not None and not np.all(background.shown):
        meta["shown"] = [bool(v) for v in background.shown]
    write_text_atomic(out / META, json.dumps(meta, indent=1))  # last: complete once it exists
    return meta


def read_background(model_dir: str | os.PathLike[str]) -> Background:
    """The background sequence :func:`write_background` kept in a model.

    Raises
    ------
    MiketalkError
        If the model keeps none, or a frame is missing.
    """
    from miketalk.media.frame_source import ImageFrames
    from miketalk.media.images import read_image

    where = Path(model_dir) / DIRECTORY
    if not (where / META).is_file():
        raise MiketalkError(
            f"the model {model_dir} keeps no background (not built from clips of a person): "
            "use --background still or a video"
        )
    meta = json.loads((where / META).read_text(encoding="utf-8"))
    paths = [where / f"{i:04d}.png" for i in range(meta["frames"])]
    frames = ImageFrames(paths, keep=len(paths))  # read once when first played, then kept
    field = np.load(where / FIELD)
    transforms = np.array(meta["transforms"], np.float64).reshape(-1, 2, 3)
    return Background(
        frames,
        transforms,
        field if field.size else None,
        float(meta["fps"]),
        tuple(meta["blinks"]),
        f"clip {meta['clip']}",
        read_image(where / STEADY),
        np.array(meta["shown"], bool) if "shown" in meta else None,
    )


class BackgroundChoice(StrEnum):
    """What ``--background`` (and a workflow face's ``background``) names, besides a video."""

    AUTO = "auto"  #: the model's own background if it keeps one, else the still face
    STILL = "still"  #: the model's still face


#: The named backgrounds, as plain strings (anything else is a video's path).
BACKGROUND_CHOICES: tuple[str, ...] = tuple(c.value for c in BackgroundChoice)


def resolve_background(
    choice: str | None, model, *, progress: bool = False, check_person: bool = True
):
    """The background of ``--background``: ``auto``, ``still`` or a video's path
    (``check_person``: as :func:`video_background`'s).

    Returns
    -------
    miketalk.composite.background.Background or None
        None for a still face (``still``, or ``auto`` with a model that keeps
        no background: the output is then exactly ``say``'s without one).

    Raises
    ------
    MiketalkError
        A video with a model not built from a person, or a video that cannot
        be read, is shorter than a second, or does not show the model's person.
    """
    choice = choice or defaults.BACKGROUND
    if choice == BackgroundChoice.STILL:
        return None
    if choice == BackgroundChoice.AUTO:
        return read_background(model.directory) if has_background(model.directory) else None
    return video_background(model.directory, choice, progress=progress, check_person=check_person)


def model_crop(model_dir: str | os.PathLike[str]) -> FaceCropSettings | None:
    """The face crop a model works in (None: the frames' own pixels, or no background)."""
    where = Path(model_dir) / DIRECTORY / META
    if not where.is_file():
        return None
    return crop_from_doc(json.loads(where.read_text(encoding="utf-8")).get("crop"))


def video_background(
    model_dir: str | os.PathLike[str],
    video: str | os.PathLike[str],
    *,
    progress: bool = False,
    check_person: bool = True,
) -> Background:
    """Any video of the model's person registered to its reference (``say --background
    VIDEO``, ``dub``): through its face crops for a model that works in one
    (:func:`~miketalk.composite.tracked.tracked_background`), else frame by frame
    (:func:`~miketalk.composite.background.background_from_video`).

    Raises
    ------
    MiketalkError
        A model not built from a person, or a video that cannot be read, is shorter
        than a second, or does not show the model's person (refused before it is tracked
        when a first look at a few frames finds no face, :mod:`miketalk.track.first_look`,
        or another person's, :mod:`miketalk.track.identity`, unless ``check_person`` is
        False: ``--force``).
    """
    stabilizer = model_stabilizer(model_dir)
    crop = model_crop(model_dir)
    if crop is not None:
        from miketalk.track.first_look import first_look

        first_look(video, source=str(video))  # no face anywhere: said before tracking it all
    if check_person:
        from miketalk.media.images import read_image
        from miketalk.track.identity import check_person as check

        check(read_image(Path(model_dir) / DIRECTORY / REFERENCE), video, source=str(video))
    if crop is not None:
        from miketalk.composite.tracked import tracked_background

        return tracked_background(video, stabilizer, crop, source=str(video), progress=progress)
    from miketalk.composite.background import streamed_background

    return streamed_background(video, stabilizer, source=str(video), progress=progress)


def composite_renders(
    renders: Iterable[np.ndarray], background: Background, model, *, fps: float
) -> Iterator[np.ndarray]:
    """:func:`composited` with the model's mouth box, size and silence image.

    Parameters
    ----------
    renders : iterable of numpy.ndarray
        The model's frames.
    background : Background
    model : miketalk.model.face.Model
        A model built from clips (:func:`has_background`).
    fps : float
        The output's frame rate.
    """
    from miketalk.visemes import SILENCE

    compositor = model_compositor(model.directory, model.size)
    rest = model.image(SILENCE) if SILENCE in model.visemes else None
    return composited(renders, background, compositor, fps=fps, rest=rest)
