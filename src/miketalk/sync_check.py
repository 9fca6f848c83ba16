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

from miketalk.lipsync import Timeline, largest_step, plan, synchronize
from miketalk.metrics import lag_frames, mouth_opening, psnr
from miketalk.model import Model
from miketalk.speech.festival import FestivalBackend
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
    """Where each keyframe's viseme shows: the frame most like the viseme image.

    Among the frames within two of the keyframe's time, the one whose mouth
    region is closest (mean squared error) to the viseme image, ties going to
    the frame nearest the keyframe; reported as its offset from the keyframe
    time in frames (the target is |offset| <= 0.5).
    """
    rows = []
    fps = timeline.fps
    for key in timeline.keyframes:
        centre = key.time * fps
        lo = max(0, int(np.floor(centre)) - 2)
        hi = min(len(frames) - 1, int(np.ceil(centre)) + 2)
        ks = np.arange(lo, hi + 1)
        image = model.image(key.viseme).astype(np.float64)
        err = [np.mean((frames[k].astype(np.float64) - image)[mouth] ** 2) for k in ks]
        order = np.lexsort((np.abs(ks - centre), np.round(err, 6)))
        k = int(ks[order[0]])
        rows.append(
            {
                "viseme": key.viseme,
                "phone": timeline.phones[key.phone].name,
                "time": key.time,
                "frame": k,
                "offset_frames": k - centre,
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
