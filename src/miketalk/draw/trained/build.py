"""The trained face's folder: fitted by the workflow, read by ``say``.

The folder (a model keeps it as its ``trained/``:
:attr:`miketalk.model.face.Model.trained_face`) holds

``patches.npy``, ``description.npz``, ``frames.json``
    every training frame's description and patch (:mod:`~miketalk.draw.trained.mouths`);
``trajectory.npz``
    the trajectory models' arrays, their keys prefixed ``window.``, ``regularized.`` and
    ``heard.``;
``trained.json``
    ``format``, the default trajectory model, each model's settings and its
    cross-validation report, the settings it was fitted with and the selection's.

:func:`fit_trained` writes it (``trained.json`` last: without it the face has
no trained model); :func:`read_trained` reads it back, refusing in one line a
model that lacks it; :func:`render_trained` draws a timeline with it.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from miketalk.draw.trained.gains import (
    HELD_OUT,
    amplitude_gain,
    cv_amplitude_gain,
    held_out_rows,
    read_held_out,
)
from miketalk.draw.trained.mouths import MouthFrames, load_frames, measure_frames
from miketalk.draw.trained.pooled import fit_pooled, frame_geometry, from_arrays, to_arrays
from miketalk.draw.trained.selection import SelectionSettings, drawn, select
from miketalk.draw.trained.training import (
    FitSettings,
    clip_offsets,
    training_set,
)
from miketalk.draw.trained.trajectory import (
    HEARD_HALF,
    TRAJECTORIES,
    Context,
    RegularizedTrajectory,
    WindowRegression,
    fit_regularized,
    fit_window,
)
from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import Timeline
from miketalk.speech.acoustic import Recording
from miketalk.visemes import VisemeTable

log = logging.getLogger(__name__)

#: Format tag of the trained face's manifest.
FORMAT = "miketalk-trained/1"


#: The trained face's manifest in its folder, written last (as
#: :data:`miketalk.model.parts.TRAINED_MANIFEST` names it).
MANIFEST = "trained.json"


@dataclass(frozen=True)
class TrainedFace:
    """A trained face read from a model directory.

    Attributes
    ----------
    frames : MouthFrames
        Every training frame.
    trajectories : dict
        ``name -> model`` (:data:`~miketalk.draw.trained.trajectory.TRAJECTORIES`).
    default : str
        The trajectory model used unless another is asked for.
    selection : SelectionSettings
    table : VisemeTable
        The phone-to-viseme table it was fitted with.
    report : dict
        How it was fitted (``trained.json``).
    frame_visemes : (N,) int array or None
        The viseme each training frame shows (from its clip's aligned phones, an index
        into ``table.visemes``; -1 none); None for a face fitted before they were kept.
    fitting : FitSettings
        What the trajectories were fitted with.
    """

    frames: MouthFrames
    trajectories: dict[str, WindowRegression | RegularizedTrajectory]
    default: str
    selection: SelectionSettings
    table: VisemeTable
    report: dict
    frame_visemes: np.ndarray | None = None
    fitting: FitSettings = field(default_factory=FitSettings)

    def kind_for(self, kind: str | None, *, recorded: bool) -> str:
        """The trajectory model to use: ``kind``, else ``heard`` for an utterance driven by a
        recording (``recorded``) when the face has it, else the face's default."""
        from miketalk.lipsync.settings import check_trajectory

        if kind is None:  # a recording: the build's choice (:func:`choose_trajectory`), else heard
            chosen = self.report.get("recording", "heard")
            kind = next((k for k in (chosen, "heard") if recorded and k in self.trajectories),
                        self.default)  # fmt: skip
        check_trajectory(kind, lipsync_model="trained", recorded=recorded)
        if kind not in self.trajectories:
            raise MiketalkError(
                f"this trained face has no trajectory model {kind!r} "
                f"(it has {', '.join(self.trajectories)})"
            )
        return kind

    def trajectory(
        self, timeline: Timeline, *, kind: str | None = None, recording: Recording | None = None
    ) -> np.ndarray:
        """The predicted description at each frame's time (plus the selection's ``lead``),
        ``(n_frames, n)``."""
        kind = self.kind_for(kind, recorded=recording is not None)
        times = self.read_at(timeline)
        return self.trajectories[kind].predict(timeline.phones, times, self.table, recording)

    def read_at(self, timeline: Timeline) -> np.ndarray:
        """The times the trajectory is read at: each frame's, plus the selection's ``lead``."""
        return np.array([f.time for f in timeline.frames], float) + self.selection.lead

    def described(self, kind: str | None = None) -> np.ndarray:
        """The training frames' descriptions as the trajectories predict them: with
        ``centred``, each less its clip's mean (:func:`clip_offsets`); for ``pooled``, the
        frames' mouth geometry (:func:`~.pooled.frame_geometry`)."""
        if kind == "pooled":
            return self.trajectories["pooled"].geometry
        if not self.fitting.centred:
            return self.frames.coords
        return self.frames.coords - clip_offsets(self.frames)[self.frames.clip]

    def target(
        self, timeline: Timeline, *, kind: str | None = None, recording: Recording | None = None
    ) -> np.ndarray:
        """What the selection aims at: the trajectory, amplified (:meth:`amplified`)."""
        kind = self.kind_for(kind, recorded=recording is not None)
        target = self.trajectory(timeline, kind=kind, recording=recording)
        if self.selection.amplitude > 0:
            target = self.amplified(target, self.report["fit"][kind], kind)
        return target

    def cost_weights(self, kind: str) -> np.ndarray | None:
        """The selection's weights of the target's components (None: equal)."""
        r2 = self.report["fit"][kind].get("cv_r2") if self.selection.weighted else None
        if kind == "pooled":  # the geometry's few dimensions weigh as the description does
            return self.trajectories["pooled"].cost_weights(self.frames.variance)
        return r2

    def amplified(
        self, target: np.ndarray, fit: Mapping[str, Any], kind: str | None = None
    ) -> np.ndarray:
        """``target`` with its deviation from the frames' mean scaled by each component's gain.

        The gain is ``1 + amplitude (g_d - 1) min(1, R^2_d / gain_r2)``: ``g_d``
        the component's amplitude gain (:func:`amplitude_gain`) and ``R^2_d``
        how much of it the phones predict, so that what the phones cannot
        predict is not amplified.
        """
        s = self.selection
        g = np.asarray(fit["amplitude_gain_cv" if s.cv_gain else "amplitude_gain"])
        r2 = np.asarray(fit["cv_r2"])
        share = np.minimum(1.0, r2 / s.gain_r2) if s.gain_r2 > 0 else np.ones_like(r2)
        if kind == "pooled":  # its geometry's scatter is measurement, not unpredicted motion
            share = np.ones_like(r2)
        gain = 1.0 + s.amplitude * (g - 1.0) * share
        mean = self.described(kind).mean(axis=0)
        return mean + gain * (target - mean)

    def plan(
        self,
        timeline: Timeline,
        *,
        kind: str | None = None,
        target: np.ndarray | None = None,
        recording: Recording | None = None,
    ) -> list:
        """Each frame's training frames and weights (:func:`~.selection.drawn`), aiming at
        ``target`` (default :meth:`target`, when the caller has it already)."""
        kind = self.kind_for(kind, recorded=recording is not None)
        weights = self.cost_weights(kind)
        if target is None:
            target = self.target(timeline, kind=kind, recording=recording)
        visemes = None
        if self.frame_visemes is not None and self.selection.viseme > 0:
            context = self.trajectories[kind].context
            shown = context.labels(timeline.phones, self.read_at(timeline), self.table)[1]
            visemes = (shown, self.frame_visemes)
        path = select(
            self.frames, target, self.selection, weights=weights, described=self.described(kind),
            visemes=visemes,
        )  # fmt: skip
        return drawn(self.frames, path, self.selection)


def fit_trained(
    corpus_dir: str | os.PathLike[str],
    folder: str | os.PathLike[str],
    *,
    grouping: Mapping[str, str] | None = None,
    default: str = TRAJECTORIES[0],
    components: int = 16,
    selection: SelectionSettings | None = None,
    fitting: FitSettings | None = None,
    frames: MouthFrames | None = None,
) -> dict:
    """Measure every training frame, fit the trajectory models, write them to ``folder``.

    Parameters
    ----------
    corpus_dir : path
        The face's corpus folder (training clips only).
    folder : path
        Where the trained face goes (:func:`miketalk.model.write.trained_folder`).
    grouping : dict, optional
        Viseme grouping overrides (the configuration's ``visemes.grouping``).
    default : str
        The trajectory model ``say`` uses (``window`` or ``regularized``).
    components : int
        Principal components of the description.
    selection : SelectionSettings, optional
    fitting : FitSettings, optional
    frames : MouthFrames, optional
        The training frames measured before (by another fit of the same corpus).

    Returns
    -------
    dict
        What ``trained.json`` holds.
    """
    from miketalk.media.atomic import atomic_path, write_text_atomic

    if default not in TRAJECTORIES:
        raise MiketalkError(f"trajectory model must be one of {', '.join(TRAJECTORIES)}")
    started = time.perf_counter()
    table = VisemeTable(grouping=grouping)
    selection, fitting = selection or SelectionSettings(), fitting or FitSettings()
    if frames is None:
        frames = measure_frames(corpus_dir, components=components)
    measured = time.perf_counter() - started
    held: dict[str, dict[int, np.ndarray]] = {}
    face = fitted_face(
        frames, corpus_dir, selection=selection, fitting=fitting, table=table, default=default,
        predictions=held,
    )  # fmt: skip
    window, regularized = face.trajectories["window"], face.trajectories["regularized"]
    window_report, regularized_report = (
        face.report["fit"]["window"],
        face.report["fit"]["regularized"],
    )
    out = Path(folder)
    frames.save(out)
    arrays: dict[str, np.ndarray] = {}
    settings: dict[str, Any] = {}
    for name, model in face.trajectories.items():
        a, s = to_arrays(model)
        arrays |= {f"{name}.{k}": v for k, v in a.items()}
        settings[name] = s
    arrays["frames.viseme"] = face.frame_visemes
    for name, by_clip in held.items():  # each frame's prediction by a fit without its clip
        arrays[f"{HELD_OUT}{name}"] = held_out_rows(frames, by_clip)
    with atomic_path(out / "trajectory.npz") as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)
    doc = {
        "format": FORMAT,
        "default": default,
        "trajectories": settings,
        "fitting": fitting.to_dict(),
        "selection": selection.to_dict(),
        "grouping": dict(grouping or {}),
        "fit": {
            "frames": len(frames.coords),
            "clips": len(frames.clip_ids),
            "components": components,
            "explained_variance": [float(v) for v in frames.variance],
        }
        | face.report["fit"],
    }
    write_text_atomic(out / MANIFEST, json.dumps(doc, indent=1, allow_nan=False))
    log.info(
        "trained face: %d frames (measured in %.1f s), window ridge %g (cv %.3f), "
        "regularized %g (cv %.3f), %.1f s",
        len(frames.coords), measured, window.ridge, window_report["cv_mse"][str(window.ridge)],
        regularized.smoothness, regularized_report["cv_mse"][str(regularized.smoothness)],
        time.perf_counter() - started,
    )  # fmt: skip
    return doc


def fitted_face(
    frames: MouthFrames,
    corpus_dir: str | os.PathLike[str],
    *,
    selection: SelectionSettings,
    fitting: FitSettings | None = None,
    table: VisemeTable,
    default: str = TRAJECTORIES[0],
    predictions: dict[str, dict[int, np.ndarray]] | None = None,
) -> TrainedFace:
    """The trajectory models fitted to ``frames`` (in memory) with ``fitting``: the face
    :func:`fit_trained` writes, drawing with ``selection`` (``fitting`` default
    :class:`FitSettings`). ``predictions``, when given, receives each trajectory model's
    cross-validated prediction of each clip (``name -> clip index -> (frames, n)``)."""
    fitting = fitting or FitSettings()
    data = training_set(corpus_dir, frames, leave_unsure=fitting.leave_unsure)
    if fitting.centred:
        offsets = clip_offsets(frames)
        data = dataclasses.replace(
            data, coords=tuple(c - offsets[k] for k, c in enumerate(data.coords))
        )
    context = Context.of(data.phones, table)
    held: dict[str, dict] = {name: {} for name in TRAJECTORIES}
    fitted = {
        "window": fit_window(data, context, table, half=fitting.half, predictions=held["window"]),
        "regularized": fit_regularized(data, context, table, predictions=held["regularized"]),
        "heard": fit_window(
            data, context, table, half=fitting.half, heard=HEARD_HALF, predictions=held["heard"]
        ),
        "pooled": fit_pooled(data, table, frame_geometry(frames), predictions=held["pooled"]),
    }
    if predictions is not None:
        predictions.update(held)
    for name, (model, report) in fitted.items():
        if name == "pooled":  # its gains are the geometry's, fitted with it
            continue
        report["amplitude_gain"] = amplitude_gain(model, data, table)
        report["amplitude_gain_cv"] = cv_amplitude_gain(held[name], data)
    report = {"fit": {name: report for name, (_, report) in fitted.items()}}
    left_out = sum(int((~k).sum()) for k in data.kept or ())
    report["fit"]["frames_left_out"] = left_out  # unsure words' frames (FitSettings)
    models = {name: model for name, (model, _) in fitted.items()}
    shown = np.full(len(frames.coords), -1, np.int64)
    for c, (phones, times) in enumerate(zip(data.phones, data.times, strict=True)):
        shown[frames.clip == c] = context.labels(phones, times, table)[1]
    return TrainedFace(frames, models, default, selection, table, report, shown, fitting)


def read_trained(folder: str | os.PathLike[str]) -> TrainedFace:
    """The trained face :func:`fit_trained` wrote into ``folder``.

    Raises
    ------
    MiketalkError
        In one line, when the folder holds none, or it is malformed.
    """
    d = Path(folder)
    manifest = d / MANIFEST
    if not manifest.is_file():
        raise MiketalkError(f"no trained face in {d} (no {MANIFEST})")
    try:
        doc = json.loads(manifest.read_text(encoding="utf-8"))
        if doc.get("format") != FORMAT:
            raise MiketalkError(f"{manifest} is not {FORMAT} (format {doc.get('format')!r})")
        with np.load(d / "trajectory.npz", allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        trajectories = {
            name: from_arrays(
                {
                    k.removeprefix(f"{name}."): v
                    for k, v in arrays.items()
                    if k.startswith(f"{name}.")
                },
                doc["trajectories"][name],
            )
            for name in TRAJECTORIES
            if name in doc["trajectories"]  # a face fitted before ``heard`` has not got it
        }
        # adapted to another pooled model than the package's: without it (None)
        trajectories = {k: v for k, v in trajectories.items() if v is not None}
        # a face fitted before the cross-validated gain has no amplitude_gain_cv: it keeps
        # the fitted gain it was made with, and one fitted before morphed joins its
        # cross-fades (its other later settings default to the old ways)
        old = {"cv_gain": False, "joins": "dissolve"}
        drawing = dict(doc["selection"])
        # a face fitted before the fit settings had a place of their own kept them there
        fit_keys = [f.name for f in dataclasses.fields(FitSettings) if f.name in drawing]
        fitting = FitSettings(**({k: drawing.pop(k) for k in fit_keys} | doc.get("fitting", {})))
        selection = SelectionSettings(**(old | drawing))
        table = VisemeTable(grouping=doc.get("grouping") or None)
        default = str(doc["default"])
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise MiketalkError(f"cannot read the trained face in {d}: {err!r}") from None
    visemes = arrays.get("frames.viseme")  # none in a face fitted before they were kept
    return TrainedFace(
        load_frames(d), trajectories, default, selection, table, doc, visemes, fitting
    )


__all__ = [
    "FORMAT",
    "HELD_OUT",
    "MANIFEST",
    "FitSettings",
    "TrainedFace",
    "fit_trained",
    "held_out_rows",
    "read_held_out",
    "read_trained",
]
