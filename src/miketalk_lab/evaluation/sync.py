"""Lip-sync against truth: an utterance ``say`` made vs the synthetic face speaking it.

The measured frames are the utterance's own: its timeline JSON (written by
:func:`miketalk.talk.say.say` beside the mp4) is read back and rendered with
the model's :meth:`~miketalk.model.face.Model.render`, the very call whose
frames ``say`` streams into the mp4; no speech engine runs here.

The truth is the synthetic face driven by the true parameter timeline of the
same phones: each phone's own target pose at the keyframe the lip-sync module
gives it (its middle, or its nuclei), linearly interpolated between keyframes,
as the morph interpolates between visemes. The synthesized video differs from
it by the viseme grouping (one image per group), the morph, and any timing
error; the measures below separate them.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd

from miketalk.lipsync.motion import JerkMeter, measure
from miketalk.lipsync.sampling import largest_step
from miketalk.lipsync.timeline import Timeline, plan
from miketalk.model.face import Model
from miketalk.mouth import mouth_opening
from miketalk.talk.utterance import Said
from miketalk.visemes import VisemeTable
from miketalk_lab.evaluation.measures import lag_frames, psnr

#: The key columns of a sync table: one utterance at one setting (``sampling`` is the
#: mode its JSON records: ``"blur"``, ``"paper"`` or ``"none"``).
SYNC_KEYS = ["sentence", "sampling", "fps", "max_px_per_frame"]


#: The measures of the utterance's motion in a sync table, one value each
#: (:class:`~miketalk.lipsync.motion.Motion`).
MOTION_QUANTITIES = [
    "duration_ratio", "morphs", "largest_frame_motion_px", "mean_jerk", "largest_jerk",
]  # fmt: skip


def true_parameters(timeline: Timeline, face: object) -> np.ndarray:
    """Mouth parameters of every frame of ``timeline`` from each phone's own target."""
    keys = timeline.keyframes
    per_phone: dict[int, list[int]] = {}
    for i, key in enumerate(keys):
        per_phone.setdefault(key.phone, []).append(i)
    params = []
    for i, key in enumerate(keys):
        targets = face.phone_targets(timeline.phones[key.phone].name)
        params.append(targets[per_phone[key.phone].index(i)])
    times = np.array([0.0, *(k.time for k in keys), timeline.duration])
    values = np.array([params[0], *params, params[-1]])
    frame_times = np.array([f.time for f in timeline.frames])
    return np.stack(
        [np.interp(frame_times, times, values[:, j]) for j in range(values.shape[1])], axis=1
    )


def viseme_offsets(
    frames: np.ndarray, timeline: Timeline, model: Model, mouth: np.ndarray
) -> list[dict]:
    """When the video shows each keyframe's viseme, measured from the frames.

    Each frame inside a transition A -> B is matched (mouth-region mean squared
    error) against the model's morphs of A -> B at alpha = 0, 0.02, ..., 1,
    which recovers the alpha it shows. A straight line fitted to recovered
    alpha against frame time gives the time at which the video is at alpha = 0,
    i.e. shows viseme A. Its offset from the keyframe (the phone's middle) in
    frames is reported (target: |offset| <= 0.5). Transitions covering fewer
    than two frames, or between identical visemes, say nothing and are skipped.
    """
    fps = timeline.fps
    grid = np.linspace(0.0, 1.0, 51)
    samples: dict[int, list[tuple[float, int]]] = {}
    for f in timeline.frames:
        samples.setdefault(f.transition, []).append((f.time, f.index))
    shown = frames[:, mouth].reshape(len(frames), -1).astype(np.float64)
    rows = []
    for i, t in enumerate(timeline.transitions):
        here = samples.get(i, [])
        if t.source == t.target or len(here) < 2:
            continue
        candidates = np.stack([model.frame(t.source, t.target, a)[mouth] for a in grid])
        cand = candidates.reshape(len(grid), -1).astype(np.float64)
        times = np.array([time for time, _ in here])
        observed = shown[[k for _, k in here]]
        # squared distance of every frame to every candidate: |f|^2 + |c|^2 - 2 f.c
        dist = (cand * cand).sum(axis=1)[None, :] - 2.0 * observed @ cand.T
        alphas = grid[np.argmin(dist, axis=1)]
        slope, intercept = np.polyfit(times, alphas, 1)
        if slope <= 0:
            continue
        at_zero = -intercept / slope  # the time the video shows viseme A (alpha = 0)
        key = next(k for k in timeline.keyframes if abs(k.time - t.start) < 1e-9)
        rows.append(
            {
                "viseme": t.source,
                "phone": timeline.phones[key.phone].name,
                "time": key.time,
                "frame": at_zero * fps,
                "offset_frames": (at_zero - key.time) * fps,
            }
        )
    return rows


def utterance_frames(timeline: Timeline, model: Model) -> np.ndarray:
    """The frames of ``timeline`` as :func:`~miketalk.talk.say.say` writes them, (N, H, W, 3)."""
    return np.stack(list(model.render(timeline)))


def sync_table(
    *,
    name: str,
    said: Said,
    model: Model,
    table: VisemeTable,
    mouth: np.ndarray,
    video: str | os.PathLike[str] | None = None,
    motion: Mapping[str, float | None] | None = None,
) -> pd.DataFrame:
    """Every sync measure of one utterance as tidy rows (sentence, sampling, fps,
    max_px_per_frame, quantity, key, value).

    Parameters
    ----------
    name : str
        The ``sentence`` column.
    said : Said
        The utterance's timeline JSON (:func:`miketalk.talk.utterance.read_said`);
        its ``sampling`` is the ``sampling`` column.
    model : Model
        The model that made the utterance, with the same morph options.
    table : VisemeTable
        The phone-to-viseme table it was made with (plans the un-oversampled
        timeline of ``said.planned_phones``).
    mouth : numpy.ndarray
        (H, W) bool mouth region of the synthetic face.
    video : path-like, optional
        The utterance's mp4: its decoded video and audio durations are added
        as ``mp4_video_seconds`` and ``mp4_audio_seconds``.
    motion : mapping, optional
        The measures of the utterance's motion as its JSON records them
        (``motion``, :meth:`~miketalk.lipsync.motion.Motion.to_dict`). None:
        measured here, on the frames rendered again
        (:func:`~miketalk.lipsync.motion.measure`; the same values for an
        utterance of the paper's lip-sync model).

    Returns
    -------
    pandas.DataFrame
        Per frame ``psnr_mouth`` and ``psnr_full``; ``mouth_lag_frames``,
        ``mouth_opening_corr``, ``viseme_offset_frames`` (per transition),
        ``largest_step_px`` (``plain`` and ``oversampled``), ``audio_seconds``,
        ``video_seconds``, ``duration_diff_frames``, ``lengthened_seconds``;
        the measures of the motion (``motion``): ``duration_ratio``,
        ``morphs``, ``largest_frame_motion_px``, ``mean_jerk``,
        ``largest_jerk`` (:data:`MOTION_QUANTITIES`); then the mp4's durations.
    """
    from synth_face import Face, FaceRenderer

    timeline = said.timeline
    fps = timeline.fps
    plain = plan(said.planned_phones, table, fps=fps, duration=said.planned_duration)
    frames = utterance_frames(timeline, model)
    face = Face()
    renderer = FaceRenderer(face, size=frames.shape[1])
    try:
        truth = np.stack([renderer.render(p) for p in true_parameters(timeline, face)])
    finally:
        renderer.close()
    rows: list[dict] = []

    def add(quantity: str, key: object, value: float) -> None:
        rows.append({"sentence": name, "sampling": said.sampling, "fps": fps,
                     "max_px_per_frame": said.max_px_per_frame, "quantity": quantity, "key": key,
                     "value": float(value)})  # fmt: skip

    for k in range(len(frames)):
        add("psnr_mouth", k, psnr(frames[k], truth[k], mouth))
        add("psnr_full", k, psnr(frames[k], truth[k]))
    opening, true_opening = mouth_opening(frames, mouth), mouth_opening(truth, mouth)
    add("mouth_lag_frames", "", lag_frames(opening, true_opening))
    add("mouth_opening_corr", "", np.corrcoef(opening, true_opening)[0, 1])
    for row in viseme_offsets(frames, timeline, model, mouth):
        add("viseme_offset_frames", f"{row['viseme']}@{row['time']:.3f}", row["offset_frames"])
    add("largest_step_px", "plain", largest_step(plain, model.displacement))
    add("largest_step_px", "oversampled", largest_step(timeline, model.displacement))
    add("audio_seconds", "", timeline.duration)
    add("video_seconds", "", len(frames) / fps)
    add("duration_diff_frames", "", (len(frames) / fps - timeline.duration) * fps)
    add("lengthened_seconds", "", timeline.duration - said.planned_duration)
    if motion is None:
        jerk = JerkMeter()
        for frame in frames:
            jerk.add(frame)
        natural = said.planned_duration
        motion = measure(
            timeline, model.displacement, natural_duration=natural, jerk=jerk
        ).to_dict()
    for quantity in MOTION_QUANTITIES:
        add(quantity, "", motion[quantity])
    if video is not None:
        from miketalk.media.video import probe_durations

        video_s, audio_s = probe_durations(video)
        add("mp4_video_seconds", "", video_s)
        add("mp4_audio_seconds", "", audio_s)
    return pd.DataFrame(rows)


def psnr_of_mean_mse(psnr: Iterable[float]) -> float:
    """PSNR of the mean squared error over frames, from each frame's PSNR (8-bit images).

    Averaging the error, not the decibels, keeps one bad frame from hiding
    among good ones. Infinite PSNR (an identical frame) is an error of 0; all
    frames identical give ``inf``.
    """
    mse = 255.0**2 / np.power(10.0, np.asarray(list(psnr), float) / 10.0)
    return float(10 * np.log10(255.0**2 / mse.mean())) if mse.mean() > 0 else float("inf")


def summarize_sync(table: pd.DataFrame) -> pd.DataFrame:
    """One row per utterance and setting (:data:`SYNC_KEYS`) of tidy sync tables.

    Parameters
    ----------
    table : pandas.DataFrame
        Rows of :func:`sync_table`, of any number of utterances.

    Returns
    -------
    pandas.DataFrame
        Sorted by the keys: ``frames``, ``psnr_mouth`` and ``psnr_full``
        (:func:`psnr_of_mean_mse`), ``identical_frames``, ``mouth_lag_frames``,
        ``mouth_opening_corr``, ``max_abs_viseme_offset_frames``,
        ``visemes_within_half_frame`` (fraction with ``|offset| <= 0.5``),
        ``largest_step_px_plain``, ``largest_step_px_oversampled``,
        ``audio_seconds``, ``video_seconds``, ``duration_diff_frames``,
        ``lengthened_seconds``, ``duration_ratio``, ``morphs``,
        ``largest_frame_motion_px``, ``mean_jerk``, ``largest_jerk``.
    """
    rows = []
    # dropna=False: max_px_per_frame is empty for an utterance made without a limit
    for group, part in table.groupby(SYNC_KEYS, sort=True, dropna=False):
        q = part.groupby("quantity")["value"]
        step = part[part["quantity"] == "largest_step_px"].set_index("key")["value"]
        offsets = part[part["quantity"] == "viseme_offset_frames"]["value"].abs()
        rows.append(
            dict(zip(SYNC_KEYS, group, strict=True))
            | {
                "frames": int((part["quantity"] == "psnr_full").sum()),
                "psnr_mouth": psnr_of_mean_mse(q.get_group("psnr_mouth")),
                "psnr_full": psnr_of_mean_mse(q.get_group("psnr_full")),
                "identical_frames": int(np.isinf(q.get_group("psnr_full")).sum()),
                "mouth_lag_frames": q.get_group("mouth_lag_frames").iloc[0],
                "mouth_opening_corr": q.get_group("mouth_opening_corr").iloc[0],
                "max_abs_viseme_offset_frames": offsets.max(),
                "visemes_within_half_frame": float((offsets <= 0.5 + 1e-9).mean()),
                "largest_step_px_plain": step.get("plain"),
                "largest_step_px_oversampled": step.get("oversampled"),
                "audio_seconds": q.get_group("audio_seconds").iloc[0],
                "video_seconds": q.get_group("video_seconds").iloc[0],
                "duration_diff_frames": q.get_group("duration_diff_frames").iloc[0],
                "lengthened_seconds": q.get_group("lengthened_seconds").iloc[0],
            }
            | {name: q.get_group(name).iloc[0] for name in MOTION_QUANTITIES}
        )
        rows[-1]["morphs"] = int(rows[-1]["morphs"])
    return pd.DataFrame(rows)
