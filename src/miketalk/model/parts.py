"""Model directories before they are opened: which one ``miketalk say`` uses by default,
what it holds beyond the paper's viseme images and flows, and so which lip-sync models it
can speak with (standard library only: ``miketalk say`` asks before numpy, OpenCV or
Festival start).

A model built from recorded clips also holds its learned coarticulation
(:data:`COARTICULATION`, :mod:`miketalk.draw.coarticulation`) and its trained face
(:data:`TRAINED_DIRECTORY`, :mod:`miketalk.draw.trained`); a synthetic face's model
holds neither and speaks with the paper's model only.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError, SettingError

#: The model ``miketalk say`` uses when none is given (relative to the working directory).
DEFAULT_MODEL = defaults.model_dir()

#: The learned coarticulation's file in a model directory.
COARTICULATION = "coarticulation.json"

#: The trained face's folder in a model directory, and its manifest in that folder.
TRAINED_DIRECTORY, TRAINED_MANIFEST = "trained", "trained.json"

#: The lip-sync model its build chose for a recording, on held-back seconds of its video
#: (:mod:`miketalk.building.lipsync_choice`), in a model directory.
LIPSYNC_CHOICE = "lipsync.json"


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


def is_model(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a model's folder (it holds its manifest; whether the model is
    whole is checked when it is opened, :class:`miketalk.model.face.Model`)."""
    return (Path(path) / "manifest.json").is_file()


def picture(model_dir: str | os.PathLike[str]) -> Path | None:
    """A picture of the model's face: its person's first background frame, else its rest
    viseme's image; only a regular PNG file inside the model's folder once its links are
    resolved (:func:`miketalk.model.manifest.inside`), never what a link there points to;
    else None."""
    from miketalk.model.manifest import inside

    try:
        frame = inside(model_dir, "background/0000.png", "its picture")
        if frame.is_file():
            return frame
        manifest = json.loads(
            inside(model_dir, "manifest.json", "its manifest").read_text(encoding="utf-8")
        )
        path = inside(model_dir, manifest["images"]["#"], "its picture")
    except (OSError, ValueError, KeyError, TypeError, MiketalkError):
        return None
    return path if path.suffix.lower() == ".png" and path.is_file() else None


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


def trained_default(model_dir: str | os.PathLike[str]) -> str:
    """The trajectory model the trained face in ``model_dir`` uses unless another is asked
    for (:attr:`miketalk.draw.trained.TrainedFace.default`).

    Raises
    ------
    MiketalkError
        In one line, for a model without a trained face, or one that cannot be read.
    """
    path = Path(model_dir) / TRAINED_DIRECTORY / TRAINED_MANIFEST
    if not path.is_file():
        raise missing_part(model_dir, "trained")
    try:
        return str(json.loads(path.read_text(encoding="utf-8"))["default"])
    except (OSError, ValueError, KeyError, TypeError) as err:
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


#: The least leave-clip-out R^2 of the trained face's best-predicted component (for a
#: recording: its ``heard`` trajectory's) for it to draw a recording by default: GRID s1's
#: four clips give 0.35 to 0.42; six weekly addresses without wa06 and wa08 0.00 for every
#: component (its dubs of those two follow his opening with r 0.05 and 0.22, the morph's
#: 0.46 and 0.08), without wa05 and wa07 0.26 (the second component: its dubs 0.60 and
#: 0.67, the morph's 0.30 and 0.43).
MIN_TRAINED_R2 = 0.1


def trained_predicts(model_dir: str | os.PathLike[str]) -> tuple[bool, float | None]:
    """Whether the trained face's cross-validation at its build (each clip predicted by a fit
    on the others) found any of its components predictable from the phones and the sound
    (:data:`MIN_TRAINED_R2`), and the best R^2 (None, and True, for a face fitted before it
    was measured)."""
    path = Path(model_dir) / TRAINED_DIRECTORY / TRAINED_MANIFEST
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        fit = doc["fit"]
        kind = "heard" if "heard" in fit else doc["default"]
        r2 = float(max(fit[kind]["cv_r2"]))
    except (OSError, ValueError, KeyError, TypeError):
        return True, None
    return r2 >= MIN_TRAINED_R2, r2


def built_choice(model_dir: str | os.PathLike[str]) -> dict | None:
    """What the model's build chose for a recording and its measure
    (:data:`LIPSYNC_CHOICE`: ``recording``, ``scores``, ``reason``...); None for a model
    built before the build chose (or one without a trained face).

    Raises
    ------
    MiketalkError
        In one line, for a choice that cannot be read or names no lip-sync model.
    """
    from miketalk.lipsync.settings import LIPSYNC_MODELS

    path = Path(model_dir) / LIPSYNC_CHOICE
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        if doc["recording"] not in LIPSYNC_MODELS:
            raise ValueError(f"no lip-sync model {doc['recording']!r}")
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise MiketalkError(f"cannot read the build's lip-sync choice {path}: {err!r}") from None
    return doc


def model_path(directory: str | os.PathLike[str] | None) -> Path:
    """The model directory ``directory`` names (None: the default one), checked to hold a
    model before anything is read, with a hint on how to build the default one.

    Raises
    ------
    SettingError
        No model there (naming the ``model`` setting).
    """
    path = Path(directory) if directory is not None else default_model_dir()
    if not (path / "manifest.json").exists():
        hint = (
            "build the default model with `make run` (or `snakemake --cores all model`)"
            if directory is None
            else "name a {model} directory built by the workflow or `miketalk build`"
        )
        raise SettingError(f"no model at {path}: {hint}")
    return path


def own_recording_model(model_dir: str | os.PathLike[str]) -> str | None:
    """The lip-sync model a recording is drawn with when none is asked for: the one its
    build chose on held-back seconds of its video (:func:`built_choice`); for a model built
    before that, ``paper`` when it has a trained face its build found unable to predict
    his mouth (:func:`trained_predicts`); None: the preferred order decides."""
    if (choice := built_choice(model_dir)) is not None:
        return str(choice["recording"])
    if not trained_trajectories(model_dir):
        return None
    return None if trained_predicts(model_dir)[0] else "paper"


def _learned(directory: Path, trajectory: str | None) -> None:
    from miketalk.draw.coarticulation import read_params

    read_params(directory / COARTICULATION)  # the one-line error of a malformed one


def _trained(directory: Path, trajectory: str | None) -> None:
    if trajectory is not None and trajectory not in trained_trajectories(directory):
        raise MiketalkError(
            f"the trained face in {directory} has no {trajectory} trajectory (fitted "
            "before it existed: rebuild the model)"
        )


#: What each lip-sync model beyond the paper's needs of a model: what a model without it
#: lacks, and how its small files are checked before the model is opened.
_PARTS: dict[str, tuple[str, Callable[[Path, str | None], None]]] = {
    "learned": (f"no learned coarticulation ({COARTICULATION})", _learned),
    "trained": (f"no trained face ({TRAINED_DIRECTORY}/{TRAINED_MANIFEST})", _trained),
}


def missing_part(model_dir: str | os.PathLike[str], lipsync_model: str) -> MiketalkError:
    """The one-line error of a model in ``model_dir`` without what ``lipsync_model`` needs."""
    return MiketalkError(
        f"the model at {model_dir} has {_PARTS[lipsync_model][0]}: the workflow fits one into "
        "a model built from recorded clips (e.g. results/model/s1); or use lipsync model 'paper'"
    )


def choose_lipsync_model(
    model_dir: str | os.PathLike[str],
    requested: str | None,
    *,
    trajectory: str | None = None,
    recorded: bool,
):
    """The lip-sync model of an utterance with the model in ``model_dir``: ``requested``, else
    the model's own (for a recording :func:`own_recording_model`, else
    :func:`~miketalk.lipsync.settings.resolve_lipsync_model`), checked
    against the directory by its small files alone (before Festival or numpy start; a
    coarticulation is read whole, as :attr:`miketalk.model.face.Model.coarticulation` does).

    Returns
    -------
    miketalk.lipsync.settings.LipsyncModel

    Raises
    ------
    MiketalkError
        In one line: a setting that does not fit (see ``resolve_lipsync_model``), a model
        without the learned coarticulation or the trained face asked for, a trained face
        without the trajectory asked for.
    """
    from miketalk.lipsync.settings import resolve_lipsync_model

    directory = Path(model_dir)
    if requested is None and trajectory is None and recorded:
        requested = own_recording_model(directory)
    present = lipsync_models_in(directory)
    chosen = resolve_lipsync_model(
        requested, available=present, trajectory=trajectory, recorded=recorded
    )
    if chosen.value not in present:
        raise missing_part(directory, chosen.value)
    if chosen.value in _PARTS:
        _PARTS[chosen.value][1](directory, trajectory)
    return chosen


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
    "LIPSYNC_CHOICE",
    "MIN_TRAINED_R2",
    "TRAINED_DIRECTORY",
    "TRAINED_MANIFEST",
    "built_choice",
    "choose_lipsync_model",
    "default_lipsync_model",
    "default_model_dir",
    "is_model",
    "lipsync_models_in",
    "missing_part",
    "model_path",
    "own_recording_model",
    "picture",
    "trained_default",
    "trained_predicts",
    "trained_trajectories",
    "workflow_results",
]
