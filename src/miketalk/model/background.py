"""A model's background video and tracker reference on disk: ``<model>/background/``.

``NNNN.png`` (the frames as recorded), ``field.npy`` (the clip's conform
field, empty when none), ``steady.png`` (the median of the frames stabilized
onto the reference: their light), ``reference.png`` and ``face_mask.png``
(what registers other video of the person, with the mouth box), and
``background.json`` (frame rate, frames, blinks, the mouth box, each frame's
transform, the face crop the model works in), written last: the folder is complete
once it exists.

Only :class:`miketalk.model.face.Model` reads it (:class:`KeptBackground`); the build
writes it with :func:`save_background`.
"""

from __future__ import annotations

import json
import os
from functools import cached_property
from pathlib import Path

import numpy as np

from miketalk.composite.background import Background
from miketalk.errors import MiketalkError
from miketalk.track.crop import FaceCropSettings, crop_doc, crop_from_doc

DIRECTORY = "background"
META = "background.json"
FIELD = "field.npy"
REFERENCE = "reference.png"
FACE_MASK = "face_mask.png"
STEADY = "steady.png"


def has_background(model_dir: str | os.PathLike[str]) -> bool:
    """Whether the model in ``model_dir`` keeps a background (built from video of a
    person); standard library only, before the model is opened."""
    return (Path(model_dir) / DIRECTORY / META).is_file()


class KeptBackground:
    """The background folder of the model in ``model_dir``, each file read once when asked.

    Raises
    ------
    MiketalkError
        From any of its members, if the model keeps no background (``exists`` is False).
    """

    def __init__(self, model_dir: str | os.PathLike[str], files: dict | None = None) -> None:
        self.model_dir = Path(model_dir)
        self.where = self.model_dir / DIRECTORY
        self.files = files or {}  # the manifest's: each file's size and SHA-256

    @property
    def exists(self) -> bool:
        """Whether the model keeps one."""
        return (self.where / META).is_file()

    @cached_property
    def meta(self) -> dict:
        """``background.json``."""
        if not self.exists:
            raise MiketalkError(
                f"the model {self.model_dir} was not built from video of a person (it has no "
                f"{DIRECTORY}/{META}): only such a model can play over a video"
            )
        try:
            return json.loads((self.where / META).read_text(encoding="utf-8"))
        except (OSError, ValueError) as err:
            raise MiketalkError(f"cannot read {self.where / META}: {err}") from None

    @cached_property
    def crop(self) -> FaceCropSettings | None:
        """The face crop the model works in (None: the frames' own pixels, or no background)."""
        return crop_from_doc(self.meta.get("crop")) if self.exists else None

    @cached_property
    def mouth_box(self) -> tuple[int, int, int, int]:
        """The mouth box ``(x, y, w, h)`` in the reference."""
        return tuple(int(v) for v in self.meta["mouth_box"])

    @cached_property
    def reference(self) -> np.ndarray:
        """The reference frame other video of the person registers to, (H, W, 3) uint8."""
        from miketalk.media.images import read_image

        self.meta  # noqa: B018  (a model without a background: its one-line error)
        return read_image(self.where / REFERENCE)

    @cached_property
    def face_mask(self) -> np.ndarray:
        """The reference's face, (H, W) bool."""
        from miketalk.media.images import read_image

        self.meta  # noqa: B018
        return read_image(self.where / FACE_MASK)[..., 0] > 127

    def stabilizer(self):
        """A :class:`~miketalk.stabilize.Stabilizer` onto the reference (the tracker's, in
        the crop, for a face-crop model)."""
        if self.crop is not None:
            from miketalk.corpus.clips import crop_stabilizer

            return crop_stabilizer(self.reference, self.crop)
        from miketalk.stabilize import Stabilizer

        return Stabilizer.from_reference(
            self.reference, face=self.face_mask, mouth_box=self.mouth_box
        )

    def read(self) -> Background:
        """The background sequence: its frames decoded once and kept decoded, in RGB and
        in the encoder's colours (:func:`~miketalk.media.kept_frames.kept_frames`, named by
        each frame's size and SHA-256 in the manifest), else read when first played.

        Raises
        ------
        MiketalkError
            If the model keeps none.
        """
        from miketalk.media.images import read_image
        from miketalk.media.kept_frames import KeptFrames, kept_frames

        if not self.exists:
            raise MiketalkError(
                f"the model {self.model_dir} keeps no background (not built from clips of a "
                "person): use --background still or a video"
            )
        meta = self.meta
        names = [f"{DIRECTORY}/{i:04d}.png" for i in range(meta["frames"])]
        listed = [self.files.get(name) for name in names]
        frames = kept_frames(
            [self.model_dir / name for name in names],
            identity=listed if all(listed) else None,  # else each file's stat
        )
        i420 = frames.i420 if isinstance(frames, KeptFrames) else None
        frames = frames.rgb if isinstance(frames, KeptFrames) else frames
        field = np.load(self.where / FIELD)
        transforms = np.array(meta["transforms"], np.float64).reshape(-1, 2, 3)
        return Background(
            frames,
            transforms,
            field if field.size else None,
            float(meta["fps"]),
            tuple(meta["blinks"]),
            f"clip {meta['clip']}",
            read_image(self.where / STEADY),
            np.array(meta["shown"], bool) if "shown" in meta else None,
            i420=i420,
        )


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


__all__ = ["DIRECTORY", "KeptBackground", "has_background", "save_background"]
