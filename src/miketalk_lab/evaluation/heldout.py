"""Measured against the real person: held-out clips re-synthesized and compared frame by frame.

A test clip is driven by its own audio and phone alignment at its own frame
rate, so synthesized frame ``k`` and the real (stabilized) frame ``k`` show the
same moment, ``k / fps``. Every measure compares the two on the mouth region:

``psnr_mouth``, ``ssim_mouth``
    pixels (:func:`miketalk_lab.evaluation.measures.psnr`, ``ssim``);
``sharpness_ratio``
    the synthesized mouth's fine detail over the real one's
    (:func:`miketalk_lab.evaluation.measures.sharpness`, means over the frames): under 1
    a softer picture than the video, which PSNR rewards;
``eigenlip_<i>``
    mouth shape without a learned landmark model: the mouth region projected
    on the first principal components of the *training* frames' mouth regions
    ("eigenlips", Bregler & Konig 1994; :class:`Eigenlips`); per clip the
    Pearson correlation of each coefficient's trajectory, synthesized vs real,
    and the lag in frames that maximizes their cross-correlation;
``opening``
    the mouth's mean darkness (:func:`miketalk.mouth.mouth_opening`),
    a measure a person can read: it rises as the dark interior shows;
``..._corr_speech``
    the same correlations over the frames from the first spoken phone's start
    to the last one's end only: the silences around a sentence (rest, then
    speech) dominate a whole clip's correlation; inside the speech it measures
    how well the mouth's shapes follow the phones;
``mouth_lmd``, ``lip_opening_...``, ``mouth_width_...``
    dlib's 68 face landmarks of both (:mod:`miketalk_lab.evaluation.landmark_scores`).

Renderers (:data:`RENDERERS`) put the paper's morph beside baselines that use
the same timeline and so the same frames: the silence viseme held (a still
face), the nearest viseme held (a flip-book, no morph), and a cross-dissolve
with the morph's alpha; and, for a model that has learned its person's
coarticulation (``coarticulation.json``), that model (``learned``), and for one
with a trained face (``trained/``, :mod:`miketalk.draw.trained`) its frames
drawn from the person's own along the trained trajectory (``trained``, and
``trained_regularized`` with the other trajectory model, ``trained_previous``
with the selection settings it had before they were cross-validated, ``trained_heard``
with the trajectory that hears the clip's recording as well as its phones). Calibration rows
measure the real frames themselves 1 and 2 frames late (``real_late1``,
``real_late2``; :data:`CALIBRATION_DELAYS`): what a small lag alone costs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import Timeline
from miketalk.model.face import Model
from miketalk.mouth import Eigenlips, grey_mouths, mouth_opening
from miketalk.mouth.region import Box
from miketalk.speech.acoustic import Recording
from miketalk.visemes import SILENCE
from miketalk_lab.evaluation.landmark_scores import (
    ClipLandmarks,
    landmark_scores,
    paired_differences,
)
from miketalk_lab.evaluation.landmarks import delayed
from miketalk_lab.evaluation.measures import (
    box_mask,
    lag_frames,
    psnr,
    ratio_of_means,
    sharpness,
    ssim,
)
from miketalk_lab.evaluation.measures import correlation as _corr
from miketalk_lab.evaluation.renderers import RENDERERS

#: Largest lag (frames) searched by the cross-correlation.
MAX_LAG = 5


#: The calibration rows: the real frames this many frames late (renderer ``real_late<k>``).
CALIBRATION_DELAYS = (1, 2)


@dataclass(frozen=True)
class ClipScores:
    """Per-frame rows and the per-clip summary of one clip and one renderer."""

    frames: pd.DataFrame
    summary: dict


def compare(
    real: np.ndarray,
    synthesized: np.ndarray,
    *,
    mouth_box: Box,
    eigenlips: Eigenlips,
    max_lag: int = MAX_LAG,
    speech: slice | None = None,
) -> ClipScores:
    """Every measure of a synthesized clip against its real frames (see the module docstring).

    Parameters
    ----------
    real, synthesized : (N, H, W, 3) uint8
        The same number of frames, frame ``k`` of each at ``k / fps``.
    mouth_box : (x, y, w, h)
        The mouth region.
    eigenlips : Eigenlips
        Fitted on the training frames.
    max_lag : int
        Largest lag searched, frames.
    speech : slice, optional
        The frames of the speech (:func:`speech_frames`): adds the
        ``*_corr_speech`` measures.
    """
    if real.shape != synthesized.shape:
        raise MiketalkError(f"real {real.shape} and synthesized {synthesized.shape} frames differ")
    mask = box_mask(real.shape[1:], mouth_box)
    n = len(real)
    rows = {
        "frame": np.arange(n),
        "psnr_mouth": [psnr(s, r, mask) for s, r in zip(synthesized, real, strict=True)],
        "ssim_mouth": [ssim(s, r, mask) for s, r in zip(synthesized, real, strict=True)],
        "sharpness_real": [sharpness(r, mask) for r in real],
        "sharpness_synth": [sharpness(s, mask) for s in synthesized],
    }
    coef_real = eigenlips.project(grey_mouths(real, mouth_box))
    coef_synth = eigenlips.project(grey_mouths(synthesized, mouth_box))
    open_real, open_synth = mouth_opening(real, mask), mouth_opening(synthesized, mask)
    summary: dict = {
        "frames": n,
        "psnr_mouth": _psnr_of_mean_mse(np.asarray(rows["psnr_mouth"])),
        "ssim_mouth": float(np.mean(rows["ssim_mouth"])),
        "sharpness_ratio": ratio_of_means(rows["sharpness_synth"], rows["sharpness_real"]),
        "opening_corr": _corr(open_synth, open_real),
        "opening_lag": lag_frames(open_synth, open_real, max_lag=max_lag),
    }
    for i in range(coef_real.shape[1]):
        rows[f"eigenlip{i + 1}_real"] = coef_real[:, i]
        rows[f"eigenlip{i + 1}_synth"] = coef_synth[:, i]
        summary[f"eigenlip{i + 1}_corr"] = _corr(coef_synth[:, i], coef_real[:, i])
        summary[f"eigenlip{i + 1}_lag"] = lag_frames(
            coef_synth[:, i], coef_real[:, i], max_lag=max_lag
        )
        accel = np.diff(coef_synth[:, i], 2)
        summary[f"eigenlip{i + 1}_accel_rms"] = float(np.sqrt(np.mean(accel**2)))
        summary[f"eigenlip{i + 1}_accel_rms_real"] = float(
            np.sqrt(np.mean(np.diff(coef_real[:, i], 2) ** 2))
        )
    if speech is not None:
        summary["opening_corr_speech"] = _corr(open_synth[speech], open_real[speech])
        for i in range(coef_real.shape[1]):
            summary[f"eigenlip{i + 1}_corr_speech"] = _corr(
                coef_synth[speech, i], coef_real[speech, i]
            )
    rows["opening_real"], rows["opening_synth"] = open_real, open_synth
    return ClipScores(pd.DataFrame(rows), summary)


def _psnr_of_mean_mse(values: np.ndarray) -> float:
    """PSNR of the mean squared error over frames."""
    mse = 255.0**2 / np.power(10.0, values / 10.0)
    return float(10 * np.log10(255.0**2 / mse.mean())) if mse.mean() > 0 else float("inf")


def speech_frames(timeline: Timeline) -> slice:
    """The frames from the first spoken (not silent) phone's start to the last one's end."""
    from miketalk.visemes import default_table

    table = default_table()
    spoken = [p for p in timeline.phones if SILENCE not in table.visemes_of(p.name)]
    if not spoken:
        return slice(0, 0)
    first = int(np.floor(spoken[0].start * timeline.fps))
    last = int(np.ceil(spoken[-1].end * timeline.fps))
    return slice(max(0, first), min(len(timeline.frames), last))


@dataclass(frozen=True)
class HeldoutClip:
    """A test clip ready to compare: its stabilized real frames, sound, and timeline."""

    id: str
    real: np.ndarray
    samples: np.ndarray
    rate: int
    fps: float
    timeline: Timeline


def prepare_heldout(clip, *, stabilizer, table, decode=None) -> HeldoutClip:
    """Decode, align and stabilize a test clip; its timeline at its own frame rate.

    ``clip`` is a :class:`miketalk.corpus.clip_sources.Clip`, ``stabilizer`` the
    corpus's (:func:`miketalk.corpus.clips.corpus_stabilizer`), so the test
    frames are registered to the same reference as the training frames. Frames
    before or after the speech that do not register are left out
    (:func:`miketalk.corpus.steady.stabilize_clip`).
    """
    from miketalk.corpus.clip_sources import RATE, decode_clip
    from miketalk.corpus.steady import stabilize_clip
    from miketalk.lipsync.timeline import plan

    decoded, stabilized = stabilize_clip((decode or decode_clip)(clip), stabilizer)
    real = stabilized.frames
    timeline = plan(decoded.phones, table, fps=decoded.fps, duration=len(real) / decoded.fps)
    if len(timeline.frames) != len(real):  # round(n / fps * fps) is n
        raise MiketalkError(
            f"clip {clip.id}: {len(timeline.frames)} frames planned, {len(real)} real"
        )
    return HeldoutClip(clip.id, real, decoded.samples, RATE, decoded.fps, timeline)


def evaluate_clip(
    heldout: HeldoutClip,
    models: dict[str, Model],
    *,
    mouth_box: Box,
    eigenlips: Eigenlips,
    baselines_of: str | None = None,
    landmarks=None,
) -> tuple[list[dict], pd.DataFrame, dict[str, np.ndarray]]:
    """Every renderer's scores on one clip.

    Parameters
    ----------
    heldout : HeldoutClip
    models : dict
        ``name -> Model``: each is rendered with the morph (``morph``).
    mouth_box, eigenlips
        As :func:`compare`.
    baselines_of : str, optional
        The model whose images the baselines (still, flip-book, dissolve) use;
        the calibration rows (the real frames late) are labelled with it.
    landmarks : FaceLandmarks, optional
        Adds the landmark measures (:mod:`miketalk_lab.evaluation.landmark_scores`);
        each real frame is marked once.

    Returns
    -------
    (summaries, frames, renders)
        One summary dict per renderer (``clip``, ``renderer``, ``model`` and
        the measures), the per-frame table, and the rendered frames by
        ``"<renderer>:<model>"``.
    """
    jobs = [("morph", name) for name in models]
    if baselines_of is not None:
        jobs += [(r, baselines_of) for r in ("still", "flipbook", "dissolve")]
        if "learned" in models[baselines_of].lipsync_models:
            jobs.append(("learned", baselines_of))
        kinds = models[baselines_of].trajectories
        if kinds:
            jobs += [(r, baselines_of) for r in ("trained", "trained_regularized")]
            jobs.append(("trained_previous", baselines_of))
            jobs += [(f"trained_{k}", baselines_of) for k in ("heard", "pooled") if k in kinds]
        jobs += [(f"real_late{k}", baselines_of) for k in CALIBRATION_DELAYS]
    summaries, tables, renders = [], [], {}
    speech = speech_frames(heldout.timeline)
    marks = None if landmarks is None else ClipLandmarks(landmarks, heldout.real)
    recording = Recording(heldout.samples, heldout.rate)
    for renderer, name in jobs:
        late = int(renderer.removeprefix("real_late")) if renderer.startswith("real_late") else 0
        if late:
            frames = delayed(heldout.real, late)
        else:
            render = RENDERERS[renderer](models[name], heldout.timeline, recording)
            frames = np.stack(list(render))
        scores = compare(
            heldout.real, frames, mouth_box=mouth_box, eigenlips=eigenlips, speech=speech
        )
        label = {"clip": heldout.id, "renderer": renderer, "model": name}
        per_frame, summary = scores.frames, scores.summary
        if marks is not None:
            points = marks.late(late) if late else marks.of(frames)
            columns, measures = landmark_scores(marks.real, points, speech=speech, max_lag=MAX_LAG)
            per_frame, summary = per_frame.assign(**columns), summary | measures
        summaries.append(label | summary)
        tables.append(per_frame.assign(**label))
        if not late:
            renders[f"{renderer}:{name}"] = frames
    return summaries, pd.concat(tables, ignore_index=True), renders


def side_by_side(real: np.ndarray, *columns: np.ndarray, gain: float | None = 3.0) -> np.ndarray:
    """Frames ``real | columns... | |real - first column| x gain`` side by side.

    ``gain=None`` leaves the difference column out.
    """
    if gain is None:
        return np.concatenate([real, *columns], axis=2)
    diff = np.clip(np.abs(real.astype(np.int16) - columns[0].astype(np.int16)) * gain, 0, 255)
    return np.concatenate([real, *columns, diff.astype(np.uint8)], axis=2)


def video_columns(renders: dict[str, np.ndarray], default_model: str) -> list[str]:
    """What the side-by-side videos show after the real clip: the paper's morph, then the
    learned coarticulation and the trained face (from the phones, then hearing the recording
    too) when the model has them (with none, ``|real - morph| x 3``)."""
    extra = [
        name
        for name in ("learned", "trained", "trained_heard")
        if f"{name}:{default_model}" in renders
    ]
    return ["paper", *extra] if extra else ["paper", "difference"]


def summarize(table: pd.DataFrame, *, reference: tuple[str, str] | None = None) -> pd.DataFrame:
    """Mean and spread (standard deviation) over clips of every measure, per renderer and model.

    With ``reference`` (``(renderer, model)``, the paper's morph), the landmark
    measures are also paired with it clip by clip
    (:func:`miketalk_lab.evaluation.landmark_scores.paired_differences`).
    """
    measures = [c for c in table.columns if c not in ("clip", "renderer", "model", "frames")]
    grouped = table.groupby(["renderer", "model"], sort=False)[measures]
    mean = grouped.mean().add_suffix("_mean")
    spread = grouped.std(ddof=1).add_suffix("_sd")
    out = pd.concat([mean, spread], axis=1)
    if reference is not None:
        out = out.join(paired_differences(table, reference=reference))
    out.insert(0, "clips", grouped.size())
    return out.reset_index()


def heldout_stage(
    *,
    corpus_dir,
    models: dict[str, str],
    default_model: str,
    clips: list,
    grouping: dict,
    morph: dict | None = None,
    frames_csv,
    clips_csv,
    summary_csv,
    videos_dir,
    corpus_eigenlips=None,
) -> pd.DataFrame:
    """The held-out evaluation of a face built from clips (the ``heldout`` rule).

    Parameters
    ----------
    corpus_dir : path
        The face's corpus folder (the training frames the eigenlips are fitted
        on, the stabilizer's reference, the mouth box); the test clips are read as its
        clips were (:func:`~miketalk.corpus.clips.corpus_decoder`: a face crop's tracked
        and cropped), so both are measured in the same pixels.
    models : dict
        ``name -> model directory``: each is measured with the morph.
    default_model : str
        The name in ``models`` of the face's own model: the baselines use its
        images and the side-by-side videos show it.
    clips : list of Clip
        The test clips (never read while building the model).
    grouping : dict
        Viseme grouping overrides.
    morph : dict, optional
        The face's morph settings (:class:`miketalk.render.morph.Morpher` keywords).
    frames_csv, clips_csv, summary_csv : path
        Per-frame measures, per-clip summaries, and their mean and spread.
    videos_dir : path
        One side-by-side mp4 per test clip, real | paper | learned | trained
        (those the model has; with neither: real | paper | difference x3), and its
        timeline (``<clip>.json``: the aligned phones, the frames, and the
        names of the video's ``columns``).
    corpus_eigenlips : CorpusEigenlips, optional
        The corpus's eigenlips fitted before
        (:func:`miketalk.corpus.eigenlips.read_eigenlips`); None fits them here.

    Returns
    -------
    DataFrame
        The summary.
    """
    import json
    from pathlib import Path

    from miketalk.corpus.clips import corpus_decoder, corpus_stabilizer
    from miketalk.corpus.folder import open_corpus
    from miketalk.media.atomic import write_text_atomic
    from miketalk.media.video import write_mp4
    from miketalk.mouth import mouth_region
    from miketalk.visemes import VisemeTable
    from miketalk_lab.evaluation.landmarks import face_landmarks

    box = mouth_region(corpus_dir)
    open_corpus(corpus_dir)  # complete
    if corpus_eigenlips is None:
        from miketalk.corpus.eigenlips import fit_corpus_eigenlips

        corpus_eigenlips = fit_corpus_eigenlips(corpus_dir)
    eigenlips = corpus_eigenlips.eigenlips
    stabilizer, decode = corpus_stabilizer(corpus_dir), corpus_decoder(corpus_dir)
    table = VisemeTable(grouping=grouping)
    opened = {name: Model(path, morph_options=morph) for name, path in models.items()}
    landmarks = face_landmarks()
    videos = Path(videos_dir)
    videos.mkdir(parents=True, exist_ok=True)
    summaries, frames = [], []
    for clip in clips:
        heldout = prepare_heldout(clip, stabilizer=stabilizer, table=table, decode=decode)
        rows, per_frame, renders = evaluate_clip(
            heldout,
            opened,
            mouth_box=box,
            eigenlips=eigenlips,
            baselines_of=default_model,
            landmarks=landmarks,
        )
        summaries += rows
        frames.append(per_frame)
        synth = renders[f"morph:{default_model}"]
        columns = video_columns(renders, default_model)
        write_text_atomic(
            videos / f"{clip.id}.json",
            json.dumps(heldout.timeline.to_dict() | {"columns": ["real", *columns]}, indent=1),
        )
        write_mp4(
            videos / f"{clip.id}.mp4",
            side_by_side(heldout.real, synth)
            if columns[-1] == "difference"
            else side_by_side(
                heldout.real,
                *(renders[f"{'morph' if c == 'paper' else c}:{default_model}"] for c in columns),
                gain=None,
            ),
            fps=heldout.fps,
            audio=heldout.samples,
            rate=heldout.rate,
        )
    per_clip = pd.DataFrame(summaries)
    summary = summarize(per_clip, reference=("morph", default_model))
    write_text_atomic(frames_csv, pd.concat(frames).to_csv(index=False, float_format="%.5f"))
    write_text_atomic(clips_csv, per_clip.to_csv(index=False, float_format="%.5f"))
    write_text_atomic(summary_csv, summary.to_csv(index=False, float_format="%.4f"))
    return summary


def sweep_table(summaries: dict[int, str]) -> pd.DataFrame:
    """Held-out summaries (``training clips -> summary.csv``) in one table (``training_clips``)."""
    parts = [pd.read_csv(path).assign(training_clips=n) for n, path in sorted(summaries.items())]
    return pd.concat(parts, ignore_index=True)
