"""A face's own lip-sync for a recording, chosen on held-back seconds of its training video.

A model built from clips can draw a recording with the paper's morph (``paper``), its
learned coarticulation (``learned``) or its trained face hearing the recording
(``trained``). Which follows this person's mouth best depends on how much speech the
build had and on how much his mouth's pictures differ from day to day, so the build
measures it (:func:`choose_recording_lipsync`) rather than assuming it:

- each training clip is held back in turn and its mouth predicted from its aligned
  phones (and, for the trained face, its sound) by each lip-sync model: the trained face
  refitted without it (its window regression's own cross-validation, 5 folds of clips);
  the morph's and the learned coarticulation's paths between the model's viseme images
  (their path is linear in the images, so their descriptions are the images'
  descriptions blended by the same weights);
- the judge is the crop's own mouth description (:mod:`miketalk.draw.trained.mouths`:
  the principal components of the grey mouth region, what the trained face draws by),
  never a landmark predictor: :func:`follow_score`, each component's correlation with
  the real one inside each held-back clip (what stays the same over a clip, the day's
  light and pose, is left out), weighted by how much that component moves there;
- the model chosen is the best; the paper's morph unless another beats it
  (:data:`MARGIN`); the paper's morph too when the video gives too little to judge on
  (:data:`MIN_CLIPS`, :data:`MIN_SECONDS`).

The morph's and the learned model's viseme images (and the learned model's dominance
parameters) were chosen on every training clip, the held-back one included; the trained
face never sees the clip it predicts. The comparison leans, if anything, towards the
morph, which is the fallback.

:func:`write_choice` keeps the choice in the model (:data:`miketalk.model.parts.
LIPSYNC_CHOICE`), which :func:`miketalk.model.parts.own_recording_model` reads.
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from miketalk.draw.trained.training import FitSettings
from miketalk.lipsync.settings import LIPSYNC_MODELS
from miketalk.visemes import VisemeTable

#: Format tag of the choice's file.
FORMAT = "miketalk-lipsync-choice/1"
#: The fewest training clips the choice is made on (one held back, the rest to fit on).
MIN_CLIPS = 3
#: The fewest seconds of training frames the choice is made on.
MIN_SECONDS = 6.0
#: How much higher than the morph's :func:`follow_score` another model must be to be chosen.
MARGIN = 0.02
#: How many of the description's components the judge reads (the largest).
JUDGED = 8
#: The lip-sync models judged, the fallback (the paper's morph) first.
CANDIDATES = LIPSYNC_MODELS


@dataclass(frozen=True)
class LipsyncChoice:
    """What :func:`choose_recording_lipsync` chose and why.

    Attributes
    ----------
    recording : str
        The lip-sync model a recording is drawn with (``paper``, ``learned``, ``trained``).
    scores : dict
        Each judged model's :func:`follow_score` on the held-back clips (empty: not judged).
    clips : int
        The training clips held back in turn.
    seconds : float
        Their frames' length.
    reason : str
        One line: why this model.
    """

    recording: str
    scores: dict[str, float]
    clips: int
    seconds: float
    reason: str

    def to_dict(self) -> dict:
        """JSON-ready form, with its format tag."""
        return {"format": FORMAT} | asdict(self)


def follow_score(
    real: list[np.ndarray], predicted: list[np.ndarray], judged: int = JUDGED
) -> float:
    """How well ``predicted`` follows ``real`` inside each clip (one ``(frames, n)`` array of
    descriptions per clip): per component, Pearson's r over every clip's frames, each clip
    less its own mean; averaged over the first ``judged`` components, each weighted by
    the real one's variance inside the clips. 1: follows every movement; 0: none."""
    r = np.concatenate([c[:, :judged] - c[:, :judged].mean(axis=0) for c in real])
    p = np.concatenate([c[:, :judged] - c[:, :judged].mean(axis=0) for c in predicted])
    spread = (r**2).sum(axis=0)
    den = np.sqrt(spread * (p**2).sum(axis=0))
    corr = np.divide((r * p).sum(axis=0), den, out=np.zeros_like(den), where=den > 0)
    return float((spread * corr).sum() / spread.sum()) if spread.sum() > 0 else 0.0


def _viseme_descriptions(model_dir: Path, frames) -> dict[str, np.ndarray]:
    """Each viseme image's description (the trained face's components)."""
    from miketalk.draw.trained.mouths import grey
    from miketalk.model.face import Model

    x, y, w, h = frames.region
    with Model(model_dir) as model:
        images = {v: model.image(v) for v in model.visemes}
    names = tuple(images)
    regions = grey(np.stack([images[v][y : y + h, x : x + w] for v in names]))
    return dict(zip(names, frames.project(regions), strict=True))


def _fitted_length(path: np.ndarray, n: int) -> np.ndarray:
    """``path`` cut or extended (its last row) to ``n`` rows."""
    if len(path) >= n:
        return path[:n]
    return np.concatenate([path, np.repeat(path[-1:], n - len(path), axis=0)])


def held_back_predictions(
    corpus_dir: str | os.PathLike[str], model_dir: str | os.PathLike[str], table: VisemeTable
) -> tuple[list[np.ndarray], dict[str, list[np.ndarray]]]:
    """Each training clip's real descriptions and each lip-sync model's prediction of them
    (see the module docstring); a model the face lacks is left out."""
    from miketalk.draw.coarticulation import predict_trajectory, read_params
    from miketalk.draw.coarticulation.weights import paper_trajectory
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.draw.trained.training import clip_offsets, training_set
    from miketalk.draw.trained.trajectory import HEARD_HALF, Context, fit_window
    from miketalk.lipsync.timeline import keyframes, plan
    from miketalk.model.parts import COARTICULATION, TRAINED_DIRECTORY

    model_dir = Path(model_dir)
    frames = load_frames(model_dir / TRAINED_DIRECTORY)
    data = training_set(corpus_dir, frames)
    real = [np.asarray(c, float) for c in data.coords]
    targets = _viseme_descriptions(model_dir, frames)
    out: dict[str, list[np.ndarray]] = {"paper": []}
    params = None
    if (model_dir / COARTICULATION).is_file():
        params, out["learned"] = read_params(model_dir / COARTICULATION), []
    for phones, coords in zip(data.phones, real, strict=True):
        n = len(coords)
        timeline = plan(phones, table, fps=frames.fps, duration=n / frames.fps)
        out["paper"].append(_fitted_length(paper_trajectory(timeline, targets), n))
        if params is not None:
            keys = keyframes(phones, table)
            times = np.arange(n) / frames.fps
            path = predict_trajectory(keys, times, params, targets, rendered=True)
            out["learned"].append(path)
    fitting = _fitting(model_dir)
    if fitting.centred:  # as the face was fitted: each clip less its mean
        offsets = clip_offsets(frames)
        data = dataclasses.replace(
            data, coords=tuple(c - offsets[k] for k, c in enumerate(data.coords))
        )
    held: dict[int, np.ndarray] = {}
    context = Context.of(data.phones, table)
    fit_window(data, context, table, half=fitting.half, heard=HEARD_HALF, predictions=held)
    out["trained"] = [held[i] for i in range(len(real))]
    return real, out


def _fitting(model_dir: Path) -> FitSettings:
    """The settings the model's trained face was fitted with."""
    from miketalk.model.parts import TRAINED_DIRECTORY, TRAINED_MANIFEST

    doc = json.loads((model_dir / TRAINED_DIRECTORY / TRAINED_MANIFEST).read_text("utf-8"))
    return FitSettings(**doc.get("fitting", {}))


def choose_recording_lipsync(
    corpus_dir: str | os.PathLike[str],
    model_dir: str | os.PathLike[str],
    *,
    grouping: dict[str, str] | None = None,
) -> LipsyncChoice:
    """The lip-sync model a recording of this face is drawn with, judged on its held-back
    training clips (see the module docstring).

    Parameters
    ----------
    corpus_dir : path
        The face's corpus folder (its training clips).
    model_dir : path
        The model built from it, with its trained face (and coarticulation, if fitted).
    grouping : dict, optional
        Viseme grouping overrides (the configuration's ``visemes.grouping``).
    """
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.model.parts import TRAINED_DIRECTORY

    frames = load_frames(Path(model_dir) / TRAINED_DIRECTORY)
    clips, seconds = len(frames.clip_ids), round(len(frames.coords) / frames.fps, 2)
    if clips < MIN_CLIPS or seconds < MIN_SECONDS:
        return LipsyncChoice(
            "paper", {}, clips, seconds,
            f"too little to judge on ({clips} clips, {seconds:.1f} s; at least {MIN_CLIPS} "
            f"clips and {MIN_SECONDS:g} s): the paper's morph",
        )  # fmt: skip
    real, predicted = held_back_predictions(corpus_dir, model_dir, VisemeTable(grouping=grouping))
    scores = {name: round(follow_score(real, predicted[name]), 4) for name in predicted}
    best = max(scores, key=lambda name: (scores[name], -CANDIDATES.index(name)))
    figures = ", ".join(f"{name} {scores[name]:.2f}" for name in CANDIDATES if name in scores)
    where = f"on {clips} held-back clips, {seconds:.0f} s ({figures})"
    if scores[best] < scores["paper"] + MARGIN:
        reason = f"none followed his mouth better than the paper's morph {where}"
        return LipsyncChoice("paper", scores, clips, seconds, reason)
    return LipsyncChoice(best, scores, clips, seconds, f"it followed his mouth best {where}")


def write_choice(model_dir: str | os.PathLike[str], choice: LipsyncChoice) -> Path:
    """Keep ``choice`` in the model (:data:`miketalk.model.parts.LIPSYNC_CHOICE`)."""
    from miketalk.media.atomic import write_text_atomic
    from miketalk.model.parts import LIPSYNC_CHOICE

    path = Path(model_dir) / LIPSYNC_CHOICE
    write_text_atomic(path, json.dumps(choice.to_dict(), indent=1, allow_nan=False))
    return path


__all__ = [
    "CANDIDATES",
    "FORMAT",
    "JUDGED",
    "MARGIN",
    "MIN_CLIPS",
    "MIN_SECONDS",
    "LipsyncChoice",
    "choose_recording_lipsync",
    "follow_score",
    "held_back_predictions",
    "write_choice",
]
