"""Lip-sync against truth: a synthesized utterance vs the synthetic face speaking it.

The truth is the synthetic face driven by the true parameter timeline of the
same phones: each phone's own target pose at the keyframe the lip-sync module
gives it (its middle, or its nuclei), linearly interpolated between keyframes,
as the morph interpolates between visemes. The synthesized video differs from
it by the viseme grouping (one image per group), the morph, and any timing
error; the measures below separate them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from miketalk.evaluation.measures import lag_frames, mouth_opening, psnr
from miketalk.speech.festival import FestivalBackend
from miketalk.talk.lipsync import Timeline, largest_step, plan, synchronize
from miketalk.talk.model import Model
from miketalk.visemes import VisemeTable


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


def sync_table(
    *,
    name: str,
    text: str,
    model: Model,
    table: VisemeTable,
    mouth: np.ndarray,
    fps: float,
    max_px_per_frame: float | None,
    backend: FestivalBackend | None = None,
) -> pd.DataFrame:
    """Every sync measure of one sentence as tidy rows (quantity, key, value)."""
    from synth_face import Face, FaceRenderer

    backend = backend or FestivalBackend()
    spoken = backend.synthesize(text)
    plain = plan(spoken.phones, table, fps, spoken.duration)
    utterance, timeline = synchronize(
        spoken,
        table,
        fps=fps,
        displacement=model.displacement,
        max_px_per_frame=max_px_per_frame,
        backend=backend,
    )
    frames = np.stack(list(model.render(timeline)))
    face = Face()
    renderer = FaceRenderer(face, size=frames.shape[1])
    try:
        truth = np.stack([renderer.render(p) for p in true_parameters(timeline, face)])
    finally:
        renderer.close()
    rows: list[dict] = []

    def add(quantity: str, key: object, value: float) -> None:
        rows.append({"sentence": name, "fps": fps, "max_px_per_frame": max_px_per_frame,
                     "quantity": quantity, "key": key, "value": float(value)})  # fmt: skip

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
    add("audio_seconds", "", utterance.duration)
    add("video_seconds", "", len(frames) / fps)
    add("duration_diff_frames", "", (len(frames) / fps - utterance.duration) * fps)
    add("lengthened_seconds", "", utterance.duration - spoken.duration)
    return pd.DataFrame(rows)
