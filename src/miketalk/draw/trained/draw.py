"""The trained face drawn: a timeline's frames from the person's own, onto the model's face."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from miketalk.draw.trained.build import TrainedFace
from miketalk.draw.trained.selection import PatchCompositor
from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import Timeline
from miketalk.speech.acoustic import Recording
from miketalk.visemes import SILENCE


def render_trained(
    model: Any,
    timeline: Timeline,
    *,
    trained: TrainedFace | None = None,
    kind: str | None = None,
    selection: Mapping[str, Any] | None = None,
    recording: Recording | None = None,
) -> Iterator[np.ndarray]:
    """The frames of ``timeline`` drawn from the person's own frames.

    Each frame's time (its middle sample; a motion-blurred frame's samples
    are not used) gets the trajectory's prediction; the selection chooses the
    training frames and they are composited onto the model's silence image.
    The ``(model, timeline)`` signature of the held-out evaluation's renderers.
    ``selection`` overrides some of the face's selection settings (not those it was
    fitted with, :class:`~miketalk.draw.trained.training.FitSettings`). ``recording``,
    the sound that drives the timeline, lets a face with the ``heard`` trajectory hear
    it (unless ``kind`` names another).
    """
    trained = trained or model.trained_face
    if selection:
        known, fitted = trained.selection.to_dict(), trained.fitting.to_dict()
        if refit := sorted(k for k in set(selection) & set(fitted) if selection[k] != fitted[k]):
            raise MiketalkError(f"{', '.join(refit)}: fitted with the model; refit it instead")
        if unknown := sorted(set(selection) - set(known) - set(fitted)):
            raise MiketalkError(
                f"unknown selection setting {', '.join(unknown)} (known: {', '.join(known)})"
            )
        selection = {k: v for k, v in selection.items() if k in known}
        settings = dataclasses.replace(trained.selection, **selection)
        trained = dataclasses.replace(trained, selection=settings)
    rows = trained.plan(timeline, kind=kind, recording=recording)
    check_patches_read(model, trained, rows)  # before the first frame is drawn
    compositor = PatchCompositor(
        trained.frames, model.image(SILENCE), joins=trained.selection.joins,
        morph_options=getattr(model, "morph_options", None),
    )  # fmt: skip
    for row in rows:
        yield compositor.frame(row)


def check_patches_read(model: Any, trained: TrainedFace, rows: list) -> int:
    """Ask the model to check the bytes of its trained face's ``patches.npy`` that ``rows``
    read against their blocks' SHA-256 in its manifest
    (:meth:`miketalk.model.face.Model.check_trained_patches`): the file is too large to hash
    whole at every open, and only these frames are read.

    Returns
    -------
    int
        The blocks checked (0 for a model without block checksums, or patches in memory).
    """
    patches = trained.frames.patches
    check = getattr(model, "check_trained_patches", None)
    if not isinstance(patches, np.memmap) or check is None or not len(patches):
        return 0
    used = sorted({int(s) for row in rows for s, _ in row})
    step = patches.strides[0]
    return check([(patches.offset + s * step, patches.offset + (s + 1) * step) for s in used])


__all__ = ["check_patches_read", "render_trained"]
