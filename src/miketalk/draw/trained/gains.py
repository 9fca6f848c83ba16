"""What the trained face keeps of its cross-validation, and its trajectories' amplitude gains.

:func:`held_out_rows` and :func:`read_held_out`: each training frame's prediction by a fit
without its clip (``trajectory.npz``'s ``held_out.<name>``); :func:`amplitude_gain` and
:func:`cv_amplitude_gain`: how much a trajectory's prediction is shrunk against the real
spread, per component.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from miketalk.draw.trained.mouths import MouthFrames
from miketalk.draw.trained.training import TrainingSet
from miketalk.visemes import VisemeTable

#: The prefix of ``trajectory.npz``'s keys of each trajectory model's cross-validated
#: predictions of the training frames (each clip by a fit without it).
HELD_OUT = "held_out."


def held_out_rows(frames: MouthFrames, by_clip: Mapping[int, np.ndarray]) -> np.ndarray:
    """``(N, n)``: each training frame's row of its clip's array in ``by_clip``."""
    width = next(iter(by_clip.values())).shape[1] if by_clip else frames.coords.shape[1]
    rows = np.zeros((len(frames.coords), width))
    for c, predicted in by_clip.items():
        rows[frames.clip == c] = predicted
    return rows


def read_held_out(folder: str | os.PathLike[str], name: str) -> np.ndarray | None:
    """What :func:`fit_trained` kept of trajectory model ``name``'s cross-validated
    predictions (:func:`held_out_rows`), or None (a face fitted before they were kept)."""
    with np.load(Path(folder) / "trajectory.npz", allow_pickle=False) as z:
        key = f"{HELD_OUT}{name}"
        return z[key] if key in z.files else None


def cv_amplitude_gain(predictions: Mapping[int, np.ndarray], data: TrainingSet) -> list[float]:
    """Per component, the real spread over the spread of the cross-validated predictions
    (each clip predicted by a model fitted without it; >= 1): the shrinkage a new sentence's
    trajectory has, whatever the number of training clips."""
    return _spread_ratio([predictions[i] for i in range(len(data.coords))], data)


def amplitude_gain(model, data: TrainingSet, table: VisemeTable) -> list[float]:
    """Per component, the real spread over the predicted one on the training clips (>= 1).

    A least-squares prediction is shrunk towards the mean where the phones
    leave the mouth uncertain; the selection, aiming at it, would then choose
    frames that move less than he does. Scaling the predicted deviation from
    the mean by this gain gives the target his own amplitude.
    """
    recordings = data.recordings or (None,) * len(data.phones)
    return _spread_ratio(
        [
            model.predict(p, t, table, r)
            for p, t, r in zip(data.phones, data.times, recordings, strict=True)
        ],
        data,
    )


def _spread_ratio(predicted: list[np.ndarray], data: TrainingSet) -> list[float]:
    """Per component, the clips' real spread over ``predicted``'s (one array per clip; both on
    the frames the fits learn from, :attr:`TrainingSet.kept`), clipped to 1 to 4."""
    return spread_ratio(data.fitted_rows(predicted), data.fitted_rows(data.coords))


def spread_ratio(predicted: list[np.ndarray], real) -> list[float]:
    """Per component, the spread of ``real`` (one array per clip) over ``predicted``'s,
    clipped to 1 to 4."""
    spread = np.concatenate(predicted).std(axis=0)
    gain = np.concatenate(real).std(axis=0) / np.where(spread > 0, spread, 1.0)
    return [round(float(g), 6) for g in np.clip(gain, 1.0, 4.0)]


__all__ = [
    "HELD_OUT",
    "amplitude_gain",
    "cv_amplitude_gain",
    "held_out_rows",
    "read_held_out",
    "spread_ratio",
]
