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
- the model chosen is the best over all the held-back clips, if it beats the paper's
  morph clip by clip: the mean of its paired differences at least :data:`MIN_T` of their
  standard errors (:func:`paired_t`); else the paper's morph, which is also the choice
  when the video gives too little to judge on (:data:`MIN_CLIPS`, :data:`MIN_SECONDS`).

The morph's and the learned model's viseme images (and the learned model's dominance
parameters) were chosen on every training clip, the held-back one included; the trained
face never sees the clip it predicts. The comparison leans, if anything, towards the
morph, which is the fallback. The frames of words heard without confidence
(:mod:`miketalk.corpus.unsure`) are not judged, as the trained face is not fitted to them
(:class:`~miketalk.draw.trained.training.FitSettings` ``leave_unsure``).

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

from miketalk.lipsync.settings import LIPSYNC_MODELS
from miketalk.visemes import VisemeTable

#: Format tag of the choice's file.
FORMAT = "miketalk-lipsync-choice/1"
#: The fewest training clips the choice is made on (one held back, the rest to fit on).
MIN_CLIPS = 3
#: The fewest seconds of training frames the choice is made on.
MIN_SECONDS = 6.0
#: How many standard errors of the clips' paired differences in :func:`follow_score` a
#: model must beat the one in use by to replace it (:func:`paired_t`): the paper's morph,
#: and the trained face fitted to the descriptions as they are. Six weekly addresses give 8
#: clips of 14 to 18 s in all: the trained face against the morph t 0.7 (fold without
#: wa06, wa08; its dubs of those two follow his opening worse than the morph's, by the
#: landmark judge), 4.1 and 2.8 (the two other folds: better); s1's 8 clips 2.2, 40 clips 6.0.
MIN_T = 2.0
#: How many of the description's components the judge reads (the largest).
JUDGED = 8
#: The lip-sync models judged, the fallback (the paper's morph) first; ``pooled`` is the
#: trained face along its pooled trajectory (:mod:`miketalk.draw.trained.pooled`).
CANDIDATES = (*LIPSYNC_MODELS, "pooled")


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
    t : dict
        Each judged model's :func:`paired_t` against the paper's morph.
    clip_scores : dict
        Each judged model's :func:`follow_score` on each held-back clip.
    trained_fits : dict
        The trained face's score fitted to the descriptions as they are (``measured``) and
        to each clip's less its mean (``centred``), when both were fitted
        (:func:`fit_and_choose`); ``scores`` holds the one kept.
    """

    recording: str
    scores: dict[str, float]
    clips: int
    seconds: float
    reason: str
    t: dict[str, float] = dataclasses.field(default_factory=dict)
    clip_scores: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    trained_fits: dict[str, float] = dataclasses.field(default_factory=dict)
    trajectory: str | None = None  # with ``trained``: its trajectory for a recording

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


def paired_t(better: list[float], worse: list[float]) -> float:
    """How many standard errors the mean of ``better - worse`` (per clip) is above 0 (0 for
    one clip; the standard error at least 1e-6, so a difference the same on every clip is
    finite)."""
    d = np.asarray(better, float) - np.asarray(worse, float)
    if len(d) < 2:
        return 0.0
    se = max(float(d.std(ddof=1)) / np.sqrt(len(d)), 1e-6)
    return round(float(d.mean() / se), 3)


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
    corpus_dir: str | os.PathLike[str],
    model_dir: str | os.PathLike[str],
    table: VisemeTable,
    trained: str | os.PathLike[str] | None = None,
    *,
    centred: bool = False,
) -> tuple[list[np.ndarray], dict[str, list[np.ndarray]]]:
    """Each training clip's real descriptions and each lip-sync model's prediction of them
    (see the module docstring), the trained face's from its folder ``trained`` (default
    the model's; with ``centred``, its heard trajectory fitted again to each clip's
    descriptions less the clip's mean, in memory); a model the face lacks is left out."""
    from miketalk.draw.coarticulation import predict_trajectory, read_params
    from miketalk.draw.coarticulation.weights import paper_trajectory
    from miketalk.draw.trained.build import read_trained
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.draw.trained.training import training_set
    from miketalk.lipsync.timeline import keyframes, plan
    from miketalk.model.parts import COARTICULATION, TRAINED_DIRECTORY

    model_dir = Path(model_dir)
    trained = Path(trained) if trained is not None else model_dir / TRAINED_DIRECTORY
    frames = load_frames(trained)
    fitting = read_trained(trained).fitting
    data = training_set(corpus_dir, frames, leave_unsure=fitting.leave_unsure)
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
    out["trained"] = _trained_drawn(trained, data, table, centred=centred)
    if (trained / "trajectory.npz").is_file() and _has_pooled(trained):
        out["pooled"] = _trained_drawn(trained, data, table, centred=centred, kind="pooled")
    # judged on the frames the fits learn from: not the unsure words' (FitSettings)
    return data.fitted_rows(real), {name: data.fitted_rows(p) for name, p in out.items()}


def _has_pooled(folder: Path) -> bool:
    from miketalk.draw.trained.build import read_trained

    return "pooled" in read_trained(folder).trajectories


def _trained_drawn(
    folder: Path, data, table: VisemeTable, *, centred: bool = False, kind: str = "heard"
) -> list[np.ndarray]:
    """Each training clip as the trained face draws it without that clip: its trajectory
    (``kind``: heard or pooled) predicted by a fit without it, and the training frames of
    the other clips the selection chooses along it; their descriptions. The pooled one is
    the same fitted to the descriptions as they are or centred (it predicts the geometry)."""
    from miketalk.draw.trained.build import read_trained
    from miketalk.draw.trained.gains import read_held_out
    from miketalk.draw.trained.selection import select

    face = read_trained(folder)
    frames = face.frames
    kept = read_held_out(folder, kind)
    if centred and not face.fitting.centred and kind == "heard":
        face, held = _heard_centred(face, data, table)
    elif kept is not None:  # the build's own cross-validation kept them
        held = {c: kept[frames.clip == c] for c in range(len(data.coords))}
    else:  # a face fitted before: fitted again, as it was
        held = _heard_again(face, data, table)[2]
    fit = face.report["fit"][kind]
    weights = face.cost_weights(kind)
    context = face.trajectories[kind].context
    drawn = []
    for c, (phones, times) in enumerate(zip(data.phones, data.times, strict=True)):
        target = held[c]
        if face.selection.amplitude > 0:
            target = face.amplified(target, fit, kind)
        described = face.described(kind).copy()
        described[frames.clip == c] += _AWAY  # never its own frames
        visemes = None
        if face.frame_visemes is not None and face.selection.viseme > 0:
            visemes = (context.labels(phones, times, table)[1], face.frame_visemes)
        path = select(
            frames, target, face.selection, weights=weights, described=described,
            visemes=visemes,
        )  # fmt: skip
        drawn.append(np.asarray(frames.coords[path], float))
    return drawn


def _heard_again(face, data, table: VisemeTable):
    """The face's heard trajectory fitted again as its ``fitting`` says: the model, its
    report and each clip's cross-validated prediction."""
    from miketalk.draw.trained.training import clip_offsets
    from miketalk.draw.trained.trajectory import HEARD_HALF, Context, fit_window

    if face.fitting.centred:  # each clip less its mean
        offsets = clip_offsets(face.frames)
        coords = tuple(c - offsets[k] for k, c in enumerate(data.coords))
        data = dataclasses.replace(data, coords=coords)
    held: dict[int, np.ndarray] = {}
    context = Context.of(data.phones, table)
    model, report = fit_window(
        data, context, table, half=face.fitting.half, heard=HEARD_HALF, predictions=held
    )
    return model, report, held, data


def _heard_centred(face, data, table: VisemeTable):
    """``face`` as it would be fitted to each clip less its mean, as far as its heard
    trajectory draws (what :func:`~miketalk.draw.trained.build.fitted_face` fits of it
    with ``centred``), and each clip's cross-validated prediction."""
    from miketalk.draw.trained.gains import amplitude_gain, cv_amplitude_gain

    centred = dataclasses.replace(face, fitting=dataclasses.replace(face.fitting, centred=True))
    model, report, held, fitted = _heard_again(centred, data, table)
    report["amplitude_gain"] = amplitude_gain(model, fitted, table)
    report["amplitude_gain_cv"] = cv_amplitude_gain(held, fitted)
    trajectories = {**face.trajectories, "heard": model}
    doc = {**face.report, "fit": {**face.report["fit"], "heard": report}}
    return dataclasses.replace(centred, trajectories=trajectories, report=doc), held


#: How far a held-back clip's own frames are put from any target (description units).
_AWAY = 1e6


def choose_recording_lipsync(
    corpus_dir: str | os.PathLike[str],
    model_dir: str | os.PathLike[str],
    *,
    grouping: dict[str, str] | None = None,
    trained: str | os.PathLike[str] | None = None,
    centred: bool = False,
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
    trained : path, optional
        The trained face's folder (default the model's).
    centred : bool
        Judge the trained face as if fitted to each clip less its mean (its heard
        trajectory fitted again in memory).
    """
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.model.parts import TRAINED_DIRECTORY

    trained = Path(trained) if trained is not None else Path(model_dir) / TRAINED_DIRECTORY
    frames = load_frames(trained)
    clips, seconds = len(frames.clip_ids), round(len(frames.coords) / frames.fps, 2)
    if clips < MIN_CLIPS or seconds < MIN_SECONDS:
        return LipsyncChoice(
            "paper", {}, clips, seconds,
            f"too little to judge on ({clips} clips, {seconds:.1f} s; at least {MIN_CLIPS} "
            f"clips and {MIN_SECONDS:g} s): the paper's morph",
        )  # fmt: skip
    table = VisemeTable(grouping=grouping)
    real, predicted = held_back_predictions(corpus_dir, model_dir, table, trained, centred=centred)
    scores = {name: round(follow_score(real, predicted[name]), 4) for name in predicted}
    per_clip = {
        name: [round(follow_score([r], [p]), 4) for r, p in zip(real, path, strict=True)]
        for name, path in predicted.items()
    }
    t = {name: paired_t(per_clip[name], per_clip["paper"]) for name in predicted}
    best = max(scores, key=lambda name: (scores[name], -CANDIDATES.index(name)))
    figures = ", ".join(f"{name} {scores[name]:.2f}" for name in CANDIDATES if name in scores)
    where = f"on {clips} held-back clips, {seconds:.0f} s: {figures}"
    if best == "paper" or t[best] < MIN_T:
        reason = (
            f"none followed his mouth surely better than the paper's morph {where} "
            f"({best} t {t[best]:.1f} against it, under {MIN_T:g})"
        )
        best = "paper"
    else:
        reason = f"it followed his mouth best {where} (t {t[best]:.1f} against the morph)"
    trajectory = "pooled" if best == "pooled" else None
    return LipsyncChoice(
        "trained" if trajectory else best, scores, clips, seconds, reason, t, per_clip, {},
        trajectory,
    )  # fmt: skip


def fit_and_choose(
    corpus_dir: str | os.PathLike[str],
    model_dir: str | os.PathLike[str],
    *,
    grouping: dict[str, str] | None = None,
) -> LipsyncChoice:
    """Fit the model's trained face, choose its recording's lip-sync, keep both.

    The trained face is fitted to the mouth's descriptions as they are; where the choice
    is judged (enough clips), also to each clip's descriptions less the clip's mean
    (:class:`~miketalk.draw.trained.training.FitSettings` ``centred``: a video of several
    days, whose light and framing differ from clip to clip, leaves the day out), and that
    fit is kept when it follows the held-back clips better (:data:`MIN_T`). Then the
    choice (:func:`choose_recording_lipsync`) is written (:func:`write_choice`).
    """
    import shutil

    from miketalk.draw.trained import fit_trained
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.draw.trained.training import FitSettings
    from miketalk.model.write import trained_folder

    folder = trained_folder(model_dir)
    fit_trained(corpus_dir, folder, grouping=grouping)
    choice = choose_recording_lipsync(corpus_dir, model_dir, grouping=grouping)
    if choice.scores:  # judged: the centred fit judged too, fitted whole only when kept
        centred = choose_recording_lipsync(corpus_dir, model_dir, grouping=grouping, centred=True)
        t = paired_t(centred.clip_scores["trained"], choice.clip_scores["trained"])
        fits = {"measured": choice.scores["trained"], "centred": centred.scores["trained"], "t": t}
        if t >= MIN_T:
            spare = Path(model_dir) / f".{folder.name}-centred"  # hidden: never a model's file
            try:
                fit_trained(
                    corpus_dir, spare, grouping=grouping, fitting=FitSettings(centred=True),
                    frames=load_frames(folder),
                )  # fmt: skip
                shutil.rmtree(folder)
                spare.rename(folder)
            finally:
                shutil.rmtree(spare, ignore_errors=True)
            reason = (
                f"{centred.reason}; the trained face fitted to each clip less its mean "
                f"({fits['centred']:.2f} against {fits['measured']:.2f}, t {t:.1f})"
            )
            choice = dataclasses.replace(centred, reason=reason)
        choice = dataclasses.replace(choice, trained_fits=fits)
    if choice.trajectory:  # the trained face's own trajectory for a recording
        from miketalk.draw.trained.build import MANIFEST
        from miketalk.media.atomic import write_text_atomic

        doc = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        doc["recording"] = choice.trajectory
        write_text_atomic(folder / MANIFEST, json.dumps(doc, indent=1, allow_nan=False))
    write_choice(model_dir, choice)
    return choice


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
    "MIN_CLIPS",
    "MIN_SECONDS",
    "MIN_T",
    "LipsyncChoice",
    "choose_recording_lipsync",
    "fit_and_choose",
    "follow_score",
    "held_back_predictions",
    "paired_t",
    "write_choice",
]
