"""Cross-validation of the trained face on its own training clips: choose its settings.

``python -m miketalk_lab.bench.trained_cv --corpus DIR --model DIR --out DIR [--variants ...]``

The trained face's settings (:class:`miketalk.draw.trained.selection.SelectionSettings`)
are chosen here, never on held-out clips: the face's training clips are split into
``--folds`` folds (every k-th clip); for each fold the trained face is fitted on the
other folds only (its principal components too) and renders the fold's clips from
their aligned phones, composited onto the model's silence image as ``say`` does.
Each rendering is measured against the clip's real (stabilized) frames with the
held-out evaluation's measures: dlib's mouth landmarks
(:mod:`miketalk_lab.evaluation.landmark_scores`), mouth PSNR and the first eigenlip
(:func:`miketalk_lab.evaluation.heldout.compare`). Beside them, in the description's
own terms: how well the trajectory follows the real frames' first components
(``traj_r1``..) and how closely the chosen frames follow the trajectory
(``chosen_r1``..), so that what limits the model shows. The variant ``oracle`` aims
the selection at the real frames' own descriptions instead of a prediction: what the
person's frames, the joins and the compositing reach with a perfect trajectory (the
ceiling that the prediction leaves the selection).

Writes ``clips.csv`` (per clip and variant) and ``summary.csv`` (mean, sd, and
each measure paired against the first variant clip by clip) into ``--out``.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.draw.trained.selection import PREVIOUS_SELECTION
from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench

log = logging.getLogger(__name__)

#: The ``kind`` of the ceiling: the selection aims at each real frame's own description.
ORACLE = "oracle"

#: Named variants: the settings each changes from the defaults (``key=value`` also works;
#: ``kind`` names the trajectory model, default the face's own; ``heard`` hears each clip's
#: recording; ``oracle`` is no trajectory at all but the real frames' own descriptions, what
#: the selection and the compositing reach with a perfect prediction; ``voice="kal"`` gives
#: each clip's words spoken by that Festival voice at his timing as its recording
#: (:mod:`miketalk_lab.bench.other_voice`): another speaker's recording of his sentence).
VARIANTS: dict[str, dict] = {
    "default": {},
    "previous": PREVIOUS_SELECTION,
    "heard": {"kind": "heard"},
    ORACLE: {"kind": ORACLE},
}

MEASURES = (
    "mouth_lmd", "lip_opening_corr_speech", "lip_opening_amplitude_speech",
    "mouth_width_corr_speech", "lip_opening_lag", "eigenlip1_corr_speech", "psnr_mouth",
    "sharpness_ratio",
)  # fmt: skip


def parse_variant(text: str) -> tuple[str, dict]:
    """``name`` of :data:`VARIANTS`, or ``name:key=value,key=value`` (values as JSON)."""
    name, _, rest = text.partition(":")
    if not rest:
        if name not in VARIANTS:
            raise MiketalkError(f"unknown variant {name!r} (known: {', '.join(VARIANTS)})")
        return name, dict(VARIANTS[name])
    from miketalk.draw.trained.selection import SelectionSettings
    from miketalk.draw.trained.training import FitSettings

    known = {"kind", "voice"} | {
        f.name for c in (SelectionSettings, FitSettings) for f in dataclasses.fields(c)
    }
    out = {}
    for item in rest.split(","):
        key, _, value = (part.strip() for part in item.partition("="))
        if key not in known:
            raise MiketalkError(f"variant {name}: unknown setting {key!r}")
        try:
            out[key] = json.loads(value)
        except ValueError:
            raise MiketalkError(f"variant {name}: {key}={value} is not a JSON value") from None
    return name, out


def json_object(text: str) -> dict:
    """A command-line JSON object (argparse's ``type``: a bad one is a one-line usage error)."""
    import argparse

    try:
        value = json.loads(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"not JSON: {err}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError("not a JSON object")
    return value


def refit_frames(frames, rows: np.ndarray, components: int):
    """``frames`` restricted to ``rows``, its principal components fitted on them alone."""
    from miketalk.draw.trained.mouths import describe

    patches = np.asarray(frames.patches[rows])
    coords, mean, comps, variance = describe(
        patches, patch=frames.patch, region=frames.region, components=components
    )
    clip_old = frames.clip[rows]
    kept = np.unique(clip_old)
    remap = np.full(len(frames.clip_ids), -1)
    remap[kept] = np.arange(len(kept))
    return dataclasses.replace(
        frames, coords=coords, patches=patches, border=frames.border[rows],
        clip=remap[clip_old], clip_frame=frames.clip_frame[rows],
        clip_ids=tuple(frames.clip_ids[k] for k in kept), mean=mean, components=comps,
        variance=variance,
    )  # fmt: skip


def cross_validate(
    corpus_dir: Path,
    model_dir: Path,
    variants: list[tuple[str, dict]],
    *,
    folds: int,
    limit=None,
    morph: dict | None = None,
) -> pd.DataFrame:
    """Per clip and variant, the measures (see the module docstring); ``morph`` is the face's
    morph settings, used where a variant's joins are morphed."""
    from miketalk.corpus.eigenlips import read_eigenlips
    from miketalk.corpus.folder import frame_path
    from miketalk.draw.trained.build import TrainedFace, fitted_face
    from miketalk.draw.trained.mouths import measure_frames
    from miketalk.draw.trained.selection import PatchCompositor, SelectionSettings
    from miketalk.draw.trained.training import FitSettings, training_set
    from miketalk.lipsync.timeline import plan
    from miketalk.media.images import read_image
    from miketalk.model.face import Model
    from miketalk.mouth import mouth_region
    from miketalk.mouth.region import grey_mouths
    from miketalk.visemes import SILENCE, VisemeTable
    from miketalk_lab.evaluation.heldout import compare, speech_frames
    from miketalk_lab.evaluation.landmark_scores import ClipLandmarks, landmark_scores
    from miketalk_lab.evaluation.landmarks import face_landmarks
    from miketalk_lab.evaluation.measures import correlation

    table = VisemeTable()
    everything = measure_frames(corpus_dir)
    components = everything.coords.shape[1]
    data = training_set(corpus_dir, everything)
    silence = Model(model_dir).image(SILENCE)
    eigenlips = read_eigenlips(corpus_dir / "eigenlips.npz").eigenlips
    box = mouth_region(corpus_dir)
    landmarks = face_landmarks()
    rows_out = []
    voices: dict[str, list] = {}

    def voiced(voice: str) -> list:
        """Every clip's words in Festival's ``voice`` at his timing (made once)."""
        from miketalk_lab.bench.other_voice import voiced_recordings

        if voice not in voices:
            voices[voice] = voiced_recordings(
                corpus_dir, everything.clip_ids, data.phones, voice=voice, table=table
            )
        return voices[voice]

    for fold, (train, held_out) in enumerate(data.folds(folds)):
        frames = refit_frames(
            everything, np.flatnonzero(np.isin(everything.clip, train)), components
        )
        compositors = {}  # by how the joins are blended
        # only the fit settings change the fit: variants differing in the rest share it
        fitted: dict[FitSettings, TrainedFace] = {}
        fit_keys = {f.name for f in dataclasses.fields(FitSettings)}
        faces = {}
        for name, change in variants:
            t0 = time.perf_counter()
            change = dict(change)
            kind = change.pop("kind", None)
            voice = change.pop("voice", None)
            fitting = FitSettings(**{k: v for k, v in change.items() if k in fit_keys})
            drawing = {k: v for k, v in change.items() if k not in fit_keys}
            selection = SelectionSettings(**(SelectionSettings().to_dict() | drawing))
            if fitting not in fitted:
                fitted[fitting] = fitted_face(
                    frames, corpus_dir, selection=selection, fitting=fitting, table=table
                )
            face = dataclasses.replace(fitted[fitting], selection=selection)
            faces[name] = (face, kind, voice)
            if selection.joins not in compositors:
                compositors[selection.joins] = PatchCompositor(
                    frames, silence, joins=selection.joins, morph_options=morph
                )
            log.info("fold %d %s: fitted in %.1f s", fold, name, time.perf_counter() - t0)
        for c in held_out[:limit]:
            clip_rows = np.flatnonzero(everything.clip == c)
            real = np.stack(
                [read_image(frame_path(corpus_dir / "frames", int(k))) for k in clip_rows]
            )
            timeline = plan(
                data.phones[c], table, fps=everything.fps, duration=len(real) / everything.fps
            )
            speech = speech_frames(timeline)
            sp = np.arange(len(real))[speech]
            marks = ClipLandmarks(landmarks, real)
            truth = frames.project(grey_mouths(real, frames.region))
            for name, (face, kind, voice) in faces.items():
                if kind == ORACLE:
                    target = truth
                    chosen = face.plan(timeline, target=target)
                else:
                    sound = voiced(voice)[c] if voice else data.recordings[c]
                    heard = {"kind": kind or face.default, "recording": sound}
                    target = face.target(timeline, **heard)
                    chosen = face.plan(timeline, target=target, **heard)
                compositor = compositors[face.selection.joins]
                synth = np.stack([compositor.frame(r) for r in chosen])
                _, lm = landmark_scores(marks.real, marks.of(synth), speech=speech, max_lag=5)
                scores = compare(real, synth, mouth_box=box, eigenlips=eigenlips, speech=speech)
                picked = np.array([sum(w * frames.coords[s] for s, w in r) for r in chosen])
                row = {"variant": name, "fold": fold, "clip": everything.clip_ids[c]}
                row |= {k: lm[k] if k in lm else scores.summary[k] for k in MEASURES}
                for d in range(3):
                    row[f"traj_r{d + 1}"] = correlation(target[sp, d], truth[sp, d])
                    row[f"chosen_r{d + 1}"] = correlation(picked[sp, d], target[sp, d])
                    row[f"amp{d + 1}"] = float(picked[sp, d].std() / truth[sp, d].std())
                rows_out.append(row)
    return pd.DataFrame(rows_out)


def summarize(clips: pd.DataFrame) -> pd.DataFrame:
    """Mean and sd per variant; each measure minus the first variant's, paired by clip."""
    measures = [c for c in clips.columns if c not in ("variant", "fold", "clip")]
    first = clips["variant"].iloc[0]
    base = clips[clips["variant"] == first].set_index("clip")[measures]
    out = []
    for name, part in clips.groupby("variant", sort=False):
        part = part.set_index("clip")[measures]
        row = {"variant": name, "clips": len(part)}
        for m in measures:
            row[f"{m}_mean"] = part[m].mean()
            row[f"{m}_sd"] = part[m].std(ddof=1)
            diff = part[m] - base[m].reindex(part.index)
            row[f"{m}_minus_{first}_mean"] = diff.mean()
            row[f"{m}_minus_{first}_sd"] = diff.std(ddof=1)
        out.append(row)
    return pd.DataFrame(out)


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    parser = bench_parser(__name__, __doc__, limit_help="clips per fold (default: all)")
    parser.add_argument("--corpus", type=Path, required=True, help="the face's corpus folder")
    parser.add_argument("--model", type=Path, required=True, help="the face's model directory")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--folds", type=int, default=5)
    parser.add_argument("--variants", nargs="+", default=["previous", "default"])
    parser.add_argument(
        "--morph",
        type=json_object,
        default={},
        help='the face\'s morph settings as JSON, e.g. \'{"median": false, "splat": "bilinear"}\'',
    )

    def work(args) -> str:
        variants = [parse_variant(v) for v in args.variants]
        clips = cross_validate(
            args.corpus, args.model, variants, folds=args.folds, limit=args.limit,
            morph=args.morph,
        )  # fmt: skip
        args.out.mkdir(parents=True, exist_ok=True)
        clips.to_csv(args.out / "clips.csv", index=False, float_format="%.5f")
        summary = summarize(clips)
        summary.to_csv(args.out / "summary.csv", index=False, float_format="%.4f")
        cols = ["variant", "clips"] + [f"{m}_mean" for m in MEASURES]
        cols += [f"traj_r{d}_mean" for d in (1, 2, 3)] + [f"chosen_r{d}_mean" for d in (1, 2, 3)]
        cols += [f"amp{d}_mean" for d in (1, 2, 3)]
        return summary[cols].to_string(index=False, float_format=lambda v: f"{v:.3f}")

    logging.basicConfig(level=logging.INFO, format="%(message)s")
    return run_bench(parser, argv, work)


if __name__ == "__main__":
    raise SystemExit(main())
