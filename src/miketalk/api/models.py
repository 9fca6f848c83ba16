"""Models opened for the use cases, and kept open between them (the page keeps them warm).

:class:`OpenModels` keeps the last models opened with their own background; :func:`opened`
is what ``say`` and ``dub`` open a model through, with or without it. Nothing outside
:mod:`miketalk.api` opens a model for a use case.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

log = logging.getLogger("miketalk")


class OpenModels:
    """The last models opened, kept open with their person's frames for the next ``say`` or
    ``dub`` (one thread's). A model whose manifest changed, or one of whose files changed
    since it was opened (:meth:`~miketalk.model.face.Model.changed_on_disk`), is opened again,
    and so checked again.

    Parameters
    ----------
    keep : int
        How many models to keep open.
    morph : dict, optional
        The morph's settings the models are opened with
        (:class:`~miketalk.render.morph_settings.MorphSettings`' fields; None: each model's
        own): the workflow's faces' ``morph``.
    """

    def __init__(self, keep: int = 2, *, morph: dict | None = None) -> None:
        self.keep = keep
        self.morph = morph
        self._open: dict[tuple[str, float], tuple[Any, Any]] = {}

    def get(self, model_dir: str | os.PathLike[str]) -> tuple[Any, Any]:
        """The model in ``model_dir`` and its ``auto`` background (None: a still face).

        Raises
        ------
        MiketalkError
            No model there, or one that cannot be opened.
        """
        from miketalk.composite.for_model import resolve_background
        from miketalk.model.face import open_model

        model_dir = Path(model_dir)
        try:
            key = (os.path.realpath(model_dir), (model_dir / "manifest.json").stat().st_mtime)
        except OSError:
            key = (os.path.realpath(model_dir), 0.0)
        if key in self._open and self._open[key][0].changed_on_disk():
            self._open.pop(key)[0].close()
        if key not in self._open:
            options = {} if self.morph is None else {"morph_options": self.morph}
            model = open_model(model_dir, **options)
            try:
                background = resolve_background("auto", model)
            except BaseException:
                model.close()
                raise
            self._open[key] = (model, background)
            while len(self._open) > self.keep:
                oldest = next(iter(self._open))
                self._open.pop(oldest)[0].close()
        self._open[key] = self._open.pop(key)  # the most recent last
        return self._open[key]

    def close(self) -> None:
        """Close the models kept open."""
        for model, _ in self._open.values():
            model.close()
        self._open.clear()


@contextlib.contextmanager
def opened(
    model_dir: Path,
    models: OpenModels | None,
    *,
    background: str | None = None,
    progress: bool = False,
    check_person: bool = True,
) -> Iterator[tuple[Any, Any]]:
    """The model in ``model_dir`` and the background ``background`` names (``auto``,
    ``still``, a video of the person: refused if it shows another person, unless not
    ``check_person``; None: ``auto``), from ``models`` when given (and left open there), else
    opened and closed here."""
    from miketalk.composite.for_model import resolve_background
    from miketalk.model.face import open_model

    if models is None:
        with open_model(model_dir) as model:
            log.info("model %s opened", model.directory)
            yield (
                model,
                resolve_background(background, model, progress=progress, check_person=check_person),
            )
        return
    model, own = models.get(model_dir)
    if background in (None, "auto"):
        yield model, own
    else:
        yield (
            model,
            resolve_background(background, model, progress=progress, check_person=check_person),
        )


@dataclass(frozen=True)
class ModelInfo:
    """What a model holds, read from its small files (for a list of models to choose from).

    Attributes
    ----------
    person : bool
        Built from video of a person (it can dub a video of him, and plays his own frames).
    lipsync_models : tuple of str
        The lip-sync models it has.
    own_text, own_recording : str
        The lip-sync model it draws typed text with, and a recording, unless told.
    """

    person: bool
    lipsync_models: tuple[str, ...]
    own_text: str
    own_recording: str


def describe_model(model_dir: str | os.PathLike[str]) -> ModelInfo:
    """What the model in ``model_dir`` holds (:class:`ModelInfo`).

    Raises
    ------
    MiketalkError
        A model whose small files cannot be read.
    """
    from miketalk.model.background import has_background
    from miketalk.model.parts import default_lipsync_model, lipsync_models_in

    return ModelInfo(
        person=has_background(model_dir),
        lipsync_models=tuple(lipsync_models_in(model_dir)),
        own_text=default_lipsync_model(model_dir, recorded=False),
        own_recording=default_lipsync_model(model_dir, recorded=True),
    )


def load_engine() -> None:
    """Import the engine (numpy, OpenCV, the drawing) now, so that the first call starts warm."""
    import miketalk.talk.say  # noqa: F401


def is_model(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` holds a model (:func:`miketalk.model.parts.is_model`)."""
    from miketalk.model.parts import is_model as holds

    return holds(path)


def model_picture(model_dir: str | os.PathLike[str]) -> Path | None:
    """A picture of the model's face: its person's first frame, else its rest viseme
    (:func:`miketalk.model.parts.picture`; None: neither)."""
    from miketalk.model.parts import picture

    return picture(model_dir)
