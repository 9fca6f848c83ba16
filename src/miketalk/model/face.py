"""A talking-face model, opened from its directory and asked for its parts.

Layout of a model directory::

    manifest.json        format, visemes, image size, estimator + settings,
                         each transition's largest flow displacement, and every
                         file's size and SHA-256
    visemes/<slug>.png   one image per viseme (RGB)
    flows/               the flow database (:class:`miketalk.flow.FlowDatabase`)
    coarticulation.json  the learned coarticulation (a face built from clips)
    trained/             the trained face (a face built from clips)
    background/          the background video and the tracker's reference
                         (:mod:`miketalk.model.background`)

:class:`Model` is the only reader of these files: everything else asks it (its images and
morphs, :class:`~miketalk.model.morphs.Morphs`; :attr:`Model.coarticulation`,
:attr:`Model.trained_face`, :meth:`Model.background`, :attr:`Model.crop`,
:meth:`Model.stabilizer`, :meth:`Model.drawing`), and each part is read once, when first
asked. The manifest is validated when the model is opened: strict JSON (no NaN), the
structure of ``data/model_manifest.schema.json`` (JSON Schema), every viseme with an image
and every ordered pair with a displacement, image paths inside the model directory, every
image present and of the declared size, every flow file present and whole (its OpenEXR
header and chunk table), and every file the manifest's ``files`` lists of its size and
SHA-256 (:func:`miketalk.model.manifest.check_files`, remembered for files whose size,
times and inode have not changed since: :func:`miketalk.model.manifest.checked_files`);
an error names the file.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase
from miketalk.media.images import read_image
from miketalk.model.background import KeptBackground
from miketalk.model.manifest import checked_files, files_stat, inside, read_manifest
from miketalk.model.morphs import RENDER_WORKERS, Morphs
from miketalk.model.parts import (
    COARTICULATION,
    TRAINED_DIRECTORY,
    choose_lipsync_model,
    lipsync_models_in,
    missing_part,
    model_path,
    own_recording_model,
    trained_trajectories,
)
from miketalk.render.morph_settings import MorphSettings

if TYPE_CHECKING:
    from miketalk.composite.background import Background
    from miketalk.draw.coarticulation import CoarticulationParams
    from miketalk.draw.registry import Drawing
    from miketalk.draw.trained import TrainedFace
    from miketalk.lipsync.settings import LipsyncModel
    from miketalk.stabilize import Stabilizer
    from miketalk.track.crop import FaceCropSettings


class Model(Morphs):
    """A model opened from ``directory`` (see the module docstring).

    Parameters
    ----------
    directory : path
        The model directory.
    cache_size : int
        How many transitions' morphers to keep ready.
    morph_options : dict, optional
        Some of :class:`miketalk.render.morph_settings.MorphSettings` by name, checked here (an
        unknown one is a one-line error).
    viseme_light : str, optional
        How its viseme images are brought to its face's light before the paper's morph
        draws them (:data:`miketalk.draw.trained.light.VISEME_LIGHTS`; None:
        :data:`miketalk.defaults.VISEME_LIGHT`): a face built from clips only.

    Raises
    ------
    MiketalkError
        If the directory, its manifest, an image or a flow file is missing or
        does not match the manifest.
    """

    def __init__(
        self,
        directory: str | os.PathLike[str],
        *,
        cache_size: int = 24,
        morph_options: dict | None = None,
        viseme_light: str | None = None,
    ) -> None:
        from miketalk.draw.trained.light import check_viseme_light

        self.directory = Path(directory)
        MorphSettings.of(morph_options)  # checked before anything is read
        self.viseme_light = check_viseme_light(viseme_light or defaults.VISEME_LIGHT)
        manifest = read_manifest(self.directory)
        self.manifest = manifest
        visemes = tuple(manifest["visemes"])
        size: tuple[int, int] = tuple(manifest["size"])  # (H, W)
        flows = FlowDatabase(self.directory / "flows")
        # every file before any is decoded: a damaged one is named, not decoded
        self._files_stat = checked_files(self.directory, manifest, flows, visemes)
        images: dict[str, np.ndarray] = {}
        for viseme in visemes:
            image = read_image(inside(self.directory, manifest["images"][viseme], "image"))
            if image.shape[:2] != size:
                raise MiketalkError(
                    f"viseme image {manifest['images'][viseme]} is {image.shape[1]}x"
                    f"{image.shape[0]}, the manifest says {size[1]}x{size[0]}"
                )
            images[viseme] = image
        displacement = {
            tuple(k.split("|")): float(v) for k, v in manifest["max_displacement"].items()
        }
        super().__init__(
            images, flows, displacement, size, cache_size=cache_size, morph_options=morph_options
        )
        self._kept = KeptBackground(self.directory, manifest.get("files"))

    def flow_identity(self, a: str, b: str) -> object | None:
        """The size and SHA-256 the manifest records of the file of the flows between ``a``
        and ``b`` (checked when the model was opened; None: not listed): their decoded
        arrays are kept under it (:meth:`~miketalk.model.morphs.Morphs._read_pair`)."""
        relative = self.flows.path_for(a, b).relative_to(self.directory).as_posix()
        entry = self.manifest.get("files", {}).get(relative)
        return None if entry is None else (entry["size"], entry["sha256"])

    def changed_on_disk(self) -> bool:
        """Whether a file the manifest lists was replaced, resized or touched since the
        model was opened and checked (its size, mtime or inode; a server keeping the model
        open opens it again, and so checks it again)."""
        return files_stat(self.directory, self.manifest) != self._files_stat

    def __enter__(self) -> Model:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- how its mouth is drawn -------------------------------------------------------

    def lit_image(self, viseme: str) -> np.ndarray:
        """The viseme's image as the paper's morph draws it, (H, W, 3) uint8: in its face's
        light (:attr:`lit_images`). The learned coarticulation draws :meth:`image`, as built:
        measured, it gained nothing from the light (docs/anyone.md, "The morph's viseme
        images")."""
        self._check(viseme)
        return self.lit_images[viseme]

    @cached_property
    def lit_images(self) -> dict[str, np.ndarray]:
        """Its viseme images brought to its face's light (the silence image's) by
        :attr:`viseme_light` (:func:`miketalk.draw.trained.light.lit_visemes`), found when
        first drawn; as built for a model without a trained face (its frames tell each
        image's clip) or with ``"built"``."""
        if self.viseme_light == "built" or "trained" not in self.lipsync_models:
            return self._images
        from miketalk.draw.trained.light import lit_visemes

        return lit_visemes(self._images, self.trained_face.frames, self.viseme_light)

    @property
    def lipsync_models(self) -> tuple[str, ...]:
        """The lip-sync models it has: ``paper`` always, ``learned`` with its
        coarticulation, ``trained`` with its trained face."""
        return lipsync_models_in(self.directory)

    @property
    def own_recording_model(self) -> str | None:
        """The lip-sync model it draws a recording with when none is asked for, when its
        build chose one (:func:`miketalk.model.parts.own_recording_model`); None: the
        preferred order decides."""
        return own_recording_model(self.directory)

    @property
    def trajectories(self) -> tuple[str, ...]:
        """The trajectory models of its trained face (none: no trained face)."""
        return trained_trajectories(self.directory)

    @cached_property
    def coarticulation(self) -> CoarticulationParams:
        """Its learned coarticulation (:mod:`miketalk.draw.coarticulation`); a model without
        one, or a malformed one, is a one-line :class:`MiketalkError`."""
        from miketalk.draw.coarticulation import read_params

        return self._part("learned", COARTICULATION, read_params)

    @cached_property
    def trained_face(self) -> TrainedFace:
        """Its trained face (:mod:`miketalk.draw.trained`); a model without one, or a
        malformed one, is a one-line :class:`MiketalkError`."""
        from miketalk.draw.trained import read_trained

        return self._part("trained", TRAINED_DIRECTORY, read_trained)

    def _part(self, lipsync_model: str, relative: str, read: Callable[[Path], object]):
        """The part ``lipsync_model`` draws with, read from ``relative`` by ``read``."""
        if lipsync_model not in self.lipsync_models:
            raise missing_part(self.directory, lipsync_model)
        return read(self.directory / relative)

    def check_trained_patches(self, spans: list[tuple[int, int]]) -> int:
        """Check the byte ``spans`` of the trained face's patches against their blocks'
        SHA-256 in the manifest before they are drawn
        (:func:`miketalk.model.manifest.check_parts`); the number of blocks checked."""
        from miketalk.draw.trained.mouths import PATCHES
        from miketalk.model.manifest import check_parts

        relative = f"{TRAINED_DIRECTORY}/{PATCHES}"
        return check_parts(self.directory, self.manifest, relative, spans)

    def choose_lipsync_model(
        self, requested: str | None, *, trajectory: str | None = None, recorded: bool
    ) -> LipsyncModel:
        """The lip-sync model of an utterance: ``requested``, else the model's own, checked
        against what it has (:func:`miketalk.model.parts.choose_lipsync_model`)."""
        return choose_lipsync_model(
            self.directory, requested, trajectory=trajectory, recorded=recorded
        )

    def drawing(
        self, lipsync_model: str | None = None, *, trajectory: str | None = None, recorded: bool
    ) -> Drawing:
        """What draws an utterance with ``lipsync_model`` (None: the model's own) and
        ``trajectory``: the registry's entry, given this model's part
        (:func:`miketalk.draw.registry.open_drawing`)."""
        from miketalk.draw.registry import open_drawing

        return open_drawing(self, lipsync_model, trajectory=trajectory, recorded=recorded)

    # --- the person's video: background, crop, tracker reference -----------------------

    @property
    def has_background(self) -> bool:
        """Whether it keeps a background video (built from video of a person)."""
        return self._kept.exists

    @property
    def crop(self) -> FaceCropSettings | None:
        """The face crop it works in (None: the frames' own pixels, or no background)."""
        return self._kept.crop

    @property
    def mouth_box(self) -> tuple[int, int, int, int]:
        """The mouth box ``(x, y, w, h)`` of its tracker reference."""
        return self._kept.mouth_box

    @property
    def reference(self) -> np.ndarray:
        """Its tracker reference, the frame other video of the person registers to."""
        return self._kept.reference

    @property
    def face_mask(self) -> np.ndarray:
        """The reference's face, (H, W) bool."""
        return self._kept.face_mask

    def stabilizer(self) -> Stabilizer:
        """A :class:`~miketalk.stabilize.Stabilizer` onto its tracker reference.

        Raises
        ------
        MiketalkError
            If it keeps no background (it was not built from video of a person).
        """
        return self._kept.stabilizer()

    def background(self) -> Background:
        """Its background video (read once: its frames when first played, then kept).

        Raises
        ------
        MiketalkError
            If it keeps none.
        """
        if not hasattr(self, "_background"):
            self._background = self._kept.read()
        return self._background


def open_model(directory: str | os.PathLike[str] | None, **options: object) -> Model:
    """Open a model (None: :func:`~miketalk.model.parts.default_model_dir`), with a hint on
    how to build the default one when it is missing; ``options`` go to :class:`Model`."""
    return Model(model_path(directory), **options)


__all__ = ["RENDER_WORKERS", "Model", "model_path", "open_model"]
