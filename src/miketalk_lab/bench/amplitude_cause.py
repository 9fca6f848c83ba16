"""Why two builds of one video draw the trained face's mouth with another amplitude.

``python -m miketalk_lab.bench.amplitude_cause --out OUT --build NAME=DIR ... [--refit
FRAMES:LABELS[:TAG] ...] [--window LO,HI ...] [--shift S] [--config .bench/config.yaml]
[--limit N]``

Issue 53: the face built from recognized words draws the held-out s1 clips' mouth (the
trained face hearing each recording, ``trained_heard``) with an amplitude 0.09 over the
transcript-built face's. Each ``--build`` is a :mod:`miketalk_lab.bench.recognized_build`
build folder (``model/``, ``corpus/``, ``heldout/frames.csv`` and ``clips.csv``; a build without
``heldout/`` has its real opening marked by the bench, and no ``measured`` nor ``proxy_r``);
the first is the base every other is paired against, clip by clip.

For each face the bench draws every training frame alone onto the face and marks its lip
opening (dlib, as the held-out evaluation marks the frames it draws:
:func:`frame_openings`); then, for each held-out clip, it plans the face along the clip's
phones and recording as ``trained_heard`` does and reads the opening of the frames chosen,
weighted as they are blended (:func:`planned_opening`): a proxy of the drawn mouth's
opening, checked against the opening the evaluation measured on the drawn frames (their
correlation, ``proxy_r``). Per clip it writes, each over the real opening's spread in the
speech (:data:`COLUMNS`):

``measured``
    the held-out evaluation's amplitude (``clips.csv``);
``trajectory``
    the heard trajectory, unamplified, read as an opening (the training frames' opening
    regressed on their description: :func:`opening_map`);
``target``
    the same of the target the selection aims at (the trajectory amplified,
    :meth:`~miketalk.draw.trained.build.TrainedFace.amplified`);
``drawn``, ``drawn_no_gain``, ``drawn_all_gain``
    the proxy with the face's selection settings, with no amplitude gain
    (``amplitude=0``), and with every component's gain whatever its R^2 (``gain_r2=0``).

``--refit FRAMES:LABELS`` fits a face again (:func:`miketalk.draw.trained.build.fitted_face`,
the build's own code) on build ``FRAMES``'s training frames (its corpus, eigenlips and
reference) with build ``LABELS``'s phones, mapped through the joined video's frames
(:func:`relabelled`): which of the two (the frames or the phones) moves the amplitude.
``--without-unsure BUILD`` fits ``BUILD``'s trained face again as a build now fits it: the
frames of the words its recognizer heard without confidence recorded in its corpus and left
out of every fit (:func:`without_unsure`), in memory; ``--with-unsure BUILD`` fits them (the
way before).
``--window`` takes ``LABELS``'s phones only inside those spans of the joined video (seconds),
``FRAMES``'s own elsewhere; ``--shift`` moves every phone of ``LABELS`` by ``S`` seconds (a
null: a transcript's phones a frame's half later). ``FRAMES:FRAMES`` fits the build's own face
again: its figures must be the build's to the digit.

``--trained NAME=BUILD:FOLDER`` draws the trained face kept in ``FOLDER`` (a model's
``trained/``, fitted again as a build now fits it) with ``BUILD``'s model and corpus.

``--patch-light`` lights the drawn patches as the held-out evaluation that made the builds'
``clips.csv`` did (``border`` before the ``session`` light became the default).
``--draw`` also draws ``trained_heard`` and ``trained`` of every face for real and measures
them as the held-out evaluation does (``drawn_*``, ``drawn_text_*``: for a build's own face,
its ``clips.csv`` figures).

Writes ``OUT/clips.csv`` (one row per face and clip) and ``OUT/summary.md`` (each face
minus the base: the mean difference, its sd and 95 % interval).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.draw.trained.light import PATCH_LIGHTS
from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.bench.relabelled import relabelled

ROOT = Path(__file__).resolve().parents[3]

#: Selection settings the proxy is read with, beside the face's own (``drawn``).
VARIANTS: dict[str, dict] = {
    "drawn": {},
    "drawn_no_gain": {"amplitude": 0.0},
    "drawn_all_gain": {"gain_r2": 0.0},
}

#: The per-clip figures (over the real opening's spread in the speech), in table order.
COLUMNS = ("measured", "trajectory", "target", *VARIANTS)


def frame_openings(model, face, light: str | None = None) -> np.ndarray:
    """``(N,)``: each training frame drawn alone onto ``model``'s face (as the trained face
    draws it, its patch brought to the face's light by ``light``: None, the default) and its
    inner-lip opening marked, pixels."""
    from miketalk.draw.trained.selection import PatchCompositor
    from miketalk.visemes import SILENCE
    from miketalk_lab.evaluation.landmarks import face_landmarks, lip_opening

    draw = PatchCompositor(
        face.frames, model.image(SILENCE), joins=face.selection.joins, light=light
    )
    frames = np.stack([draw.frame(((s, 1.0),)) for s in range(len(face.frames.coords))])
    marks = face_landmarks()
    return lip_opening(marks.points(frames, marks.face_box(frames)))


def opening_map(coords: np.ndarray, opening: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares opening of a description (weights, offset) and its R^2 on the
    training frames: how a trajectory or a target reads as an opening."""
    design = np.c_[coords, np.ones(len(coords))]
    beta = np.linalg.lstsq(design, opening, rcond=None)[0]
    residual = opening - design @ beta
    return beta, float(1.0 - residual.var() / opening.var())


def planned_opening(rows: Sequence, opening: np.ndarray) -> np.ndarray:
    """Each output frame's opening: its training frames' (:func:`~miketalk.draw.trained.
    selection.drawn`'s rows of ``(frame, weight)``), weighted as they are blended."""
    return np.array([sum(w * opening[s] for s, w in row) for row in rows])


def spread(values: np.ndarray, real: np.ndarray, speech: slice) -> float:
    """``values``' standard deviation over the speech, over ``real``'s (the held-out
    evaluation's amplitude)."""
    sd = float(np.std(real[speech]))
    return float(np.std(values[speech]) / sd) if sd > 0 else float("nan")


def face_rows(
    name: str,
    build: Path,
    clips,
    options: Mapping,
    face=None,
    *,
    draw: bool = False,
    light: str | None = None,
) -> list[dict]:
    """Every held-out clip's figures (:data:`COLUMNS`) for one face: ``build``'s own, or
    ``face`` (a refit) drawn with ``build``'s model and measured in its corpus's frame (a
    refit's ``measured`` and ``proxy_r`` are NaN: the evaluation drew the build's own).
    ``draw``: also draw ``trained_heard`` for real and measure it as the held-out evaluation
    does (:data:`DRAWN`; for the build's own face, its ``clips.csv`` figures when ``light``
    is the patch light its evaluation drew with)."""
    from miketalk.corpus.clips import corpus_decoder, corpus_stabilizer
    from miketalk.model.face import Model
    from miketalk.speech.acoustic import Recording
    from miketalk.visemes import VisemeTable
    from miketalk_lab.evaluation.heldout import prepare_heldout, speech_frames

    model = Model(build / "model", morph_options=options["morph_options"])
    own = face is None  # the build's own face: what the evaluation drew and measured
    face = face or model.trained_face
    opening = frame_openings(model, face, light)
    beta, fit = opening_map(face.frames.coords, opening)
    evaluated = (build / "heldout" / "frames.csv").is_file()  # else: no measured, no proxy_r
    if evaluated:
        frames = pd.read_csv(build / "heldout" / "frames.csv")
        frames = frames[frames["renderer"] == "trained_heard"]
        measured = pd.read_csv(build / "heldout" / "clips.csv")
        measured = measured[measured["renderer"] == "trained_heard"].set_index("clip")
    stabilizer, decode = corpus_stabilizer(build / "corpus"), corpus_decoder(build / "corpus")
    table = VisemeTable(grouping=options["grouping"])
    faces = {v: dataclasses.replace(face, selection=dataclasses.replace(face.selection, **o))
             for v, o in VARIANTS.items()}  # fmt: skip
    rows = []
    for clip in clips:
        held = prepare_heldout(clip, stabilizer=stabilizer, table=table, decode=decode)
        if evaluated:
            marked = frames[frames["clip"] == clip.id].sort_values("frame")
            real = marked["lip_opening_real"].to_numpy()
            drawn = marked["lip_opening_synth"].to_numpy()
        else:  # a build not evaluated: the real opening marked here
            real, drawn, own = _real_opening(held.real), None, False
        if len(real) != len(held.timeline.frames):
            raise MiketalkError(f"{name}: clip {clip.id}'s frames.csv does not match its frames")
        speech, recording = speech_frames(held.timeline), Recording(held.samples, held.rate)
        trajectory = face.trajectory(held.timeline, kind="heard", recording=recording)
        target = face.target(held.timeline, kind="heard", recording=recording)
        row = {
            "face": name, "clip": clip.id,
            "measured": float(measured.loc[clip.id, "lip_opening_amplitude_speech"])
            if own else float("nan"),
            "trajectory": spread(np.c_[trajectory, np.ones(len(trajectory))] @ beta, real, speech),
            "target": spread(np.c_[target, np.ones(len(target))] @ beta, real, speech),
            "opening_fit_r2": fit,
        }  # fmt: skip
        for v, drawing in faces.items():
            plan = drawing.plan(held.timeline, kind="heard", recording=recording)
            proxy = planned_opening(plan, opening)
            row[v] = spread(proxy, real, speech)
            if v == "drawn":
                row["proxy_r"] = float(np.corrcoef(proxy, drawn)[0, 1]) if own else float("nan")
        if draw:
            row |= _drawn_measures(model, face, held, recording, speech, light)
        rows.append(row)
    return rows


def _real_opening(real: np.ndarray) -> np.ndarray:
    """A held-out clip's real lip opening per frame, marked as the held-out evaluation marks it."""
    from miketalk_lab.evaluation.landmark_scores import ClipLandmarks
    from miketalk_lab.evaluation.landmarks import face_landmarks, lip_opening

    return lip_opening(ClipLandmarks(face_landmarks(), real).real)


#: The held-out evaluation's measures of ``trained_heard`` drawn for real (``--draw``).
DRAWN = ("lip_opening_corr_speech", "mouth_lmd", "lip_opening_amplitude_speech")


def _drawn_measures(model, face, held, recording, speech: slice, light) -> dict[str, float]:
    """``trained_heard`` of ``face`` drawn along a held-out clip (as
    :func:`~miketalk.draw.trained.draw.render_trained` draws it, with the patch ``light``),
    and ``trained`` (its default trajectory, the phones alone: ``drawn_text_*``), marked as
    the held-out evaluation marks them."""
    from miketalk.draw.trained.selection import PatchCompositor
    from miketalk.visemes import SILENCE
    from miketalk_lab.evaluation.heldout import MAX_LAG
    from miketalk_lab.evaluation.landmark_scores import ClipLandmarks, landmark_scores
    from miketalk_lab.evaluation.landmarks import face_landmarks

    marks = ClipLandmarks(face_landmarks(), held.real)
    compositor = PatchCompositor(
        face.frames, model.image(SILENCE), joins=face.selection.joins,
        morph_options=getattr(model, "morph_options", None), light=light,
    )  # fmt: skip
    out = {}
    for prefix, kind, heard in (("drawn_", "heard", recording), ("drawn_text_", None, None)):
        rows = face.plan(held.timeline, kind=kind, recording=heard)
        drawn = np.stack([compositor.frame(row) for row in rows])
        _, measures = landmark_scores(marks.real, marks.of(drawn), speech=speech, max_lag=MAX_LAG)
        out |= {f"{prefix}{k}": float(measures[k]) for k in DRAWN}
    return out


def refit(frames_of: Path, labels_of: Path, dest: Path, *, windows=None, shift: float = 0.0):
    """Build ``frames_of``'s trained face fitted again with ``labels_of``'s phones
    (:func:`relabelled`), with the build's own settings, in memory."""
    from miketalk.draw.trained.build import fitted_face
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.model.face import Model

    corpus = relabelled(frames_of / "corpus", labels_of / "corpus", dest, windows=windows,
                        shift=shift)  # fmt: skip
    own = Model(frames_of / "model").trained_face
    return fitted_face(
        load_frames(frames_of / "model" / "trained"), corpus, selection=own.selection,
        fitting=own.fitting, table=own.table, default=own.default,
    )  # fmt: skip


def without_unsure(build: Path, dest: Path, *, leave_unsure: bool = True):
    """``build``'s trained face fitted again as ``build`` fits it now (the build's own code and
    settings, in memory) on its corpus with the spans of its words heard without confidence
    recorded (``dest``: links to the corpus's files and the ``unsure.tsv``
    :func:`~miketalk.corpus.unsure.write_unsure` writes from the build's ``segments.json``):
    those frames left out of every fit (``leave_unsure``; False: fitted, the way before)."""
    from miketalk.corpus.unsure import UNSURE_TABLE, write_unsure
    from miketalk.draw.trained.build import fitted_face
    from miketalk.draw.trained.mouths import load_frames
    from miketalk.model.face import Model

    dest.mkdir(parents=True, exist_ok=True)
    for f in (build / "corpus").iterdir():
        if f.name != UNSURE_TABLE and not (dest / f.name).exists():
            (dest / f.name).symlink_to(f.resolve())
    write_unsure(dest, build / "model" / "build" / "segments.json")
    own = Model(build / "model").trained_face
    return fitted_face(
        load_frames(build / "model" / "trained"), dest, selection=own.selection,
        fitting=dataclasses.replace(own.fitting, leave_unsure=leave_unsure), table=own.table,
        default=own.default,
    )  # fmt: skip


def paired(table: pd.DataFrame, base: str) -> pd.DataFrame:
    """Each face minus ``base``, clip by clip, per :data:`COLUMNS` figure: both means, the
    difference's mean, sd and 95 % interval (normal, over the clips)."""
    a = table[table["face"] == base].set_index("clip")
    rows = []
    for name in [f for f in dict.fromkeys(table["face"]) if f != base]:
        b = table[table["face"] == name].set_index("clip")
        common = a.index.intersection(b.index)
        drawn = [f"drawn_{p}{k}" for p in ("", "text_") for k in DRAWN]
        for column in [c for c in (*COLUMNS, *drawn) if c in table]:
            diff = (b.loc[common, column] - a.loc[common, column]).dropna()
            half = 1.96 * diff.std(ddof=1) / np.sqrt(len(diff)) if len(diff) > 1 else np.nan
            rows.append({
                "face": name, "figure": column, "clips": len(diff),
                "base_mean": a.loc[common, column].mean(),
                "face_mean": b.loc[common, column].mean(),
                "diff_mean": diff.mean(), "diff_sd": diff.std(ddof=1),
                "ci_low": diff.mean() - half, "ci_high": diff.mean() + half,
            })  # fmt: skip
    return pd.DataFrame(rows)


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (the module docstring)."""
    parser = bench_parser(__name__, __doc__, limit_help="the first N held-out clips only")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--config", type=Path, default=ROOT / ".bench" / "config.yaml")
    parser.add_argument("--build", action="append", default=[], metavar="NAME=DIR",
                        help="a recognized_build build folder; the first is the base")  # fmt: skip
    parser.add_argument("--refit", action="append", default=[], metavar="FRAMES:LABELS[:TAG]")
    parser.add_argument("--window", action="append", default=[], metavar="LO,HI")
    parser.add_argument("--shift", type=float, default=0.0)
    parser.add_argument(
        "--without-unsure",
        action="append",
        default=[],
        metavar="BUILD",
        help="BUILD's face, heard fitted without its unsure words' frames",
    )
    parser.add_argument("--with-unsure", action="append", default=[], metavar="BUILD",
                        help="BUILD's face fitted again with its unsure words' frames (the way "
                        "before)")  # fmt: skip
    parser.add_argument("--trained", action="append", default=[], metavar="NAME=BUILD:FOLDER",
                        help="the trained face in FOLDER (a model's trained/), drawn with "
                        "BUILD's model and corpus")  # fmt: skip
    parser.add_argument("--patch-light", choices=PATCH_LIGHTS, default=None,
                        help="how patches are lit (default: the product's; the builds' "
                        "evaluation's own to compare with their clips.csv)")  # fmt: skip
    parser.add_argument("--draw", action="store_true",
                        help="also draw trained_heard for real and measure it")  # fmt: skip
    return run_bench(parser, argv, _work, check=_check)


def _builds(args: argparse.Namespace) -> dict[str, Path]:
    return {b.split("=", 1)[0]: Path(b.split("=", 1)[1]) for b in args.build if "=" in b}


def _check(args: argparse.Namespace) -> str | None:
    builds = _builds(args)
    if not builds or len(builds) != len(args.build):
        return "--build NAME=DIR: at least one, each named once"
    for spec in args.refit:
        parts = spec.split(":")
        if len(parts) not in (2, 3) or not set(parts[:2]) <= set(builds):
            return f"--refit {spec}: FRAMES:LABELS[:TAG], both among the --build names"
    for spec in args.trained:
        name, _, where = spec.partition("=")
        build, _, folder = where.partition(":")
        if not name or build not in builds or not (Path(folder) / "trained.json").is_file():
            return f"--trained {spec}: NAME=BUILD:FOLDER, BUILD a --build name, FOLDER a face"
    if not set(args.without_unsure) | set(args.with_unsure) <= set(builds):
        return "--without-unsure/--with-unsure BUILD: one of the --build names"
    try:
        windows = [tuple(float(x) for x in w.split(",")) for w in args.window]
    except ValueError:
        return "--window LO,HI: two numbers of seconds"
    if any(len(w) != 2 or w[1] <= w[0] for w in windows):
        return "--window LO,HI: two numbers of seconds, LO < HI"
    return None


def _work(args: argparse.Namespace) -> str:
    from miketalk.corpus.clip_sources import clip_sources
    from miketalk_lab.bench.one_video import _face

    options = _face(args.config, "s1")
    root, corpus = args.config.resolve().parents[1], options["corpus"]
    clips = clip_sources(list(corpus["test"])[: args.limit], media=str(root / corpus["media"]),
                         transcripts=root / corpus["transcripts"],
                         timings=str(root / corpus["timings"]))  # fmt: skip
    builds = _builds(args)
    windows = [tuple(float(x) for x in w.split(",")) for w in args.window] or None
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, folder in builds.items():
        rows += face_rows(name, folder, clips, options, draw=args.draw, light=args.patch_light)
    for spec in args.refit:
        frames_of, labels_of, *tag = spec.split(":")
        name = tag[0] if tag else f"{frames_of}+{labels_of}_phones"
        face = refit(builds[frames_of], builds[labels_of], args.out / f"corpus_{name}",
                     windows=windows, shift=args.shift)  # fmt: skip
        rows += face_rows(name, builds[frames_of], clips, options, face=face, draw=args.draw,
                          light=args.patch_light)  # fmt: skip
    for name in args.without_unsure:
        face = without_unsure(builds[name], args.out / f"corpus_{name}_unsure")
        print(f"{name}: {face.report['fit']['frames_left_out']} frames of unsure words left "
              "out of the fits", file=sys.stderr)  # fmt: skip
        rows += face_rows(f"{name}_without_unsure", builds[name], clips, options, face=face,
                          draw=args.draw, light=args.patch_light)  # fmt: skip
    for name in args.with_unsure:
        face = without_unsure(builds[name], args.out / f"corpus_{name}_unsure", leave_unsure=False)
        rows += face_rows(f"{name}_with_unsure", builds[name], clips, options, face=face,
                          draw=args.draw, light=args.patch_light)  # fmt: skip
    for spec in args.trained:
        from miketalk.draw.trained.build import read_trained

        name, _, where = spec.partition("=")
        build, _, folder = where.partition(":")
        rows += face_rows(name, builds[build], clips, options, face=read_trained(folder),
                          draw=args.draw, light=args.patch_light)  # fmt: skip
    table = pd.DataFrame(rows)
    table.to_csv(args.out / "clips.csv", index=False, float_format="%.5f")
    return _summary(args, table, next(iter(builds)))


def _summary(args: argparse.Namespace, table: pd.DataFrame, base: str) -> str:
    pairs = paired(table, base)
    lines = [
        f"# trained_heard's amplitude, each face against {base}: "
        f"{table['clip'].nunique()} held-out clips", "",
        "Proxy r (planned opening against the drawn frames' measured one): "
        + ", ".join(f"{f} {g:.3f}" for f, g in table.groupby("face", sort=False)["proxy_r"]
                    .mean().dropna().items()),
        "", "| face - base | figure | base | face | face - base (sd) | 95 % |", "|---" * 6 + "|",
    ]  # fmt: skip
    for r in pairs.itertuples():
        lines.append(
            f"| {r.face} - {base} | {r.figure} | {r.base_mean:.3f} | {r.face_mean:.3f} "
            f"| {r.diff_mean:+.3f} ({r.diff_sd:.3f}) | [{r.ci_low:+.3f}, {r.ci_high:+.3f}] |"
        )
    summary = "\n".join(lines) + "\n"
    (args.out / "summary.md").write_text(summary, "utf-8")
    keys = ("build", "refit", "window", "shift", "limit", "draw", "patch_light", "without_unsure",
            "with_unsure", "trained")  # fmt: skip
    settings = {k: getattr(args, k) for k in keys}
    (args.out / "settings.json").write_text(json.dumps(settings, indent=1) + "\n", "utf-8")
    return summary


if __name__ == "__main__":
    sys.exit(main())
