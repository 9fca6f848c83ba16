"""Model directories before they are opened: which one ``miketalk say`` uses by default,
what it holds beyond the paper's viseme images and flows, and so which lip-sync models it
can speak with (standard library only: ``miketalk say`` asks before Festival starts, and
Festival starts before numpy loads).

A model built from recorded clips also holds its learned coarticulation
(:data:`COARTICULATION`, :mod:`miketalk.draw.coarticulation`) and its trained face
(:data:`TRAINED_DIRECTORY`, :mod:`miketalk.draw.trained`); a synthetic face's model
holds neither and speaks with the paper's model only.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError

#: The model ``miketalk say`` uses when none is given (relative to the working directory).
DEFAULT_MODEL = defaults.model_dir()

#: The learned coarticulation's file in a model directory.
COARTICULATION = "coarticulation.json"

#: The trained face's folder in a model directory, and its manifest in that folder.
TRAINED_DIRECTORY, TRAINED_MANIFEST = "trained", "trained.json"


def workflow_results() -> list[Path]:
    """The folders where the workflow's results are looked for, first found first:
    ``$MIKETALK_RESULTS`` alone when it is set, else ``results/`` under the working
    directory and under the source checkout this package runs from."""
    if env := os.environ.get("MIKETALK_RESULTS"):
        return [Path(env)]
    checkout = Path(__file__).resolve().parents[3]  # src/miketalk/model/
    return [defaults.RESULTS, checkout / defaults.RESULTS]


def default_model_dir() -> Path:
    """``$MIKETALK_MODEL``, else the synthetic face's model in the first of
    :func:`workflow_results` that has one (the first's path when none has)."""
    if env := os.environ.get("MIKETALK_MODEL"):
        return Path(env)
    candidates = [defaults.model_dir(root=root) for root in workflow_results()]
    return next((path for path in candidates if path.exists()), candidates[0])


def trained_trajectories(model_dir: str | os.PathLike[str]) -> tuple[str, ...]:
    """The trajectory models of the trained face in ``model_dir`` (none: no trained face).

    Raises
    ------
    MiketalkError
        In one line, for a trained face's manifest that cannot be read.
    """
    path = Path(model_dir) / TRAINED_DIRECTORY / TRAINED_MANIFEST
    if not path.is_file():
        return ()
    try:
        return tuple(json.loads(path.read_text(encoding="utf-8")).get("trajectories", {}))
    except (OSError, ValueError, AttributeError) as err:
        raise MiketalkError(f"cannot read the trained face in {path.parent}: {err!r}") from None


def lipsync_models_in(model_dir: str | os.PathLike[str]) -> tuple[str, ...]:
    """The lip-sync models the model in ``model_dir`` has: ``paper`` always, ``learned``
    with its coarticulation, ``trained`` with its trained face."""
    has = {
        "paper": True,
        "learned": (Path(model_dir) / COARTICULATION).is_file(),
        "trained": bool(trained_trajectories(model_dir)),
    }
    return tuple(name for name, present in has.items() if present)


#: The least leave-clip-out R^2 of the trained face's first component (for a recording: its
#: ``heard`` trajectory's) for it to draw a recording by default: GRID s1's four clips give
#: 0.35 to 0.42, six weekly addresses 0.00 (the phones predict none of his mouth's motion in
#: a clip left out, and the trained face's dubs follow his opening with r 0.05 to 0.22).
MIN_TRAINED_R2 = 0.1


def trained_predicts(model_dir: str | os.PathLike[str]) -> tuple[bool, float | None]:
    """Whether the trained face's cross-validation at its build (each clip predicted by a fit
    on the others) found its first component predictable from the phones and the sound
    (:data:`MIN_TRAINED_R2`), and that R^2 (None, and True, for a face fitted before it was
    measured)."""
    path = Path(model_dir) / TRAINED_DIRECTORY / TRAINED_MANIFEST
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        fit = doc["fit"]
        kind = "heard" if "heard" in fit else doc["default"]
        r2 = float(fit[kind]["cv_r2"][0])
    except (OSError, ValueError, KeyError, IndexError, TypeError):
        return True, None
    return r2 >= MIN_TRAINED_R2, r2


def own_recording_model(model_dir: str | os.PathLike[str]) -> str | None:
    """``paper`` when the model has a trained face that its build found unable to predict
    his mouth (:func:`trained_predicts`): a recording is then drawn by the paper's morph by
    default; None: the preferred order decides."""
    if not trained_trajectories(model_dir):
        return None
    return None if trained_predicts(model_dir)[0] else "paper"


def default_lipsync_model(model_dir: str | os.PathLike[str], *, recorded: bool) -> str:
    """The lip-sync model for an utterance when none is asked for: for a recording the
    model's own choice (:func:`own_recording_model`), else the first of
    :data:`miketalk.lipsync.settings.PREFERRED_LIPSYNC_MODELS` (for a recording with
    ``recorded``, else for typed text) that the model in ``model_dir`` has."""
    from miketalk.lipsync.settings import resolve_lipsync_model

    present = lipsync_models_in(model_dir)
    own = own_recording_model(model_dir) if recorded else None
    return resolve_lipsync_model(own, available=present, recorded=recorded).value


__all__ = [
    "COARTICULATION",
    "DEFAULT_MODEL",
    "MIN_TRAINED_R2",
    "TRAINED_DIRECTORY",
    "TRAINED_MANIFEST",
    "default_lipsync_model",
    "default_model_dir",
    "lipsync_models_in",
    "own_recording_model",
    "trained_predicts",
    "trained_trajectories",
    "workflow_results",
]
