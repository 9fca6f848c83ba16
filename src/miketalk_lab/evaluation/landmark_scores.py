"""Landmark measures of a synthesized clip against its real frames (the held-out evaluation).

From the 68 face landmarks of each frame (:mod:`miketalk_lab.evaluation.landmarks`),
in pixels of the stabilized frame:

``mouth_lmd``, ``mouth_lmd_speech``
    the mouth landmark distance: the mean Euclidean distance between the 20
    mouth points (48-67) of the synthesized frame and of the real one, averaged
    over the clip's frames (``_speech``: over the speech only);
``lip_opening_corr_speech``, ``lip_opening_corr``
    Pearson correlation of the inner-lip opening (the mean distance of the
    inner-lip pairs 61-67, 62-66, 63-65), synthesized vs real, over the speech
    (:func:`miketalk_lab.evaluation.heldout.speech_frames`) and over the clip;
``lip_opening_amplitude_speech``
    how far the synthesized mouth opens and closes against the real one: the
    standard deviation of its opening over the speech divided by the real one's;
``mouth_width_corr_speech``
    the correlation of the mouth width (corners 48-54) over the speech;
``lip_opening_lag``
    the shift in frames that best aligns the synthesized opening to the real one
    over the clip (:func:`miketalk_lab.evaluation.measures.lag_frames`; positive when
    the synthesis is late); undefined (NaN) when either opening never changes
    (a still face has no lag: the cross-correlation of a constant is noise).

:func:`paired_differences` compares every renderer with a reference (the
paper's morph) clip by clip.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk_lab.evaluation.landmarks import (
    FaceLandmarks,
    delayed,
    lip_opening,
    mouth_lmd,
    mouth_width,
)
from miketalk_lab.evaluation.measures import correlation, lag_frames

#: The per-clip landmark measures, in the order the tables show them.
LANDMARK_MEASURES = (
    "mouth_lmd",
    "mouth_lmd_speech",
    "lip_opening_corr_speech",
    "lip_opening_amplitude_speech",
    "mouth_width_corr_speech",
    "lip_opening_corr",
    "lip_opening_lag",
)


class ClipLandmarks:
    """One clip's landmarks: its face box and its real frames' points, each measured once.

    Parameters
    ----------
    landmarks : FaceLandmarks
        The detector and predictor.
    real : (N, H, W, 3) uint8
        The clip's stabilized real frames: the face box is found on them
        (:meth:`FaceLandmarks.face_box`) and every frame of the clip is marked
        from it.
    """

    def __init__(self, landmarks: FaceLandmarks, real: np.ndarray) -> None:
        self._landmarks = landmarks
        self.box = landmarks.face_box(real)
        self._known: dict = {}  # points by grey frame: a frame two renderers draw is marked once
        self.real = landmarks.points(real, self.box, self._known)

    def of(self, frames: np.ndarray) -> np.ndarray:
        """The landmarks ``(N, 68, 2)`` of synthesized frames of the clip."""
        return self._landmarks.points(frames, self.box, self._known)

    def late(self, frames: int) -> np.ndarray:
        """The real frames' landmarks ``frames`` frames late (the real frames delayed:
        the predictor marks a frame the same wherever it stands in the clip)."""
        return delayed(self.real, frames)


def landmark_scores(
    real: np.ndarray,
    synthesized: np.ndarray,
    *,
    speech: slice,
    max_lag: int,
) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """The landmark measures of one clip (see the module docstring).

    Parameters
    ----------
    real, synthesized : (N, 68, 2) arrays
        The landmarks of the real and the synthesized frames, frame ``k`` of
        each at the same moment.
    speech : slice
        The frames of the speech.
    max_lag : int
        Largest lag searched, frames.

    Returns
    -------
    (per_frame, summary)
        Per-frame columns (``mouth_lmd``, ``lip_opening_real``,
        ``lip_opening_synth``, ``mouth_width_real``, ``mouth_width_synth``) and
        the clip's measures (:data:`LANDMARK_MEASURES`).
    """
    real, synthesized = np.asarray(real, float), np.asarray(synthesized, float)
    if real.shape != synthesized.shape or real.ndim != 3 or real.shape[1:] != (68, 2):
        raise MiketalkError(
            f"landmarks must be two (N, 68, 2) arrays, not {real.shape} and {synthesized.shape}"
        )
    lmd = mouth_lmd(synthesized, real)
    open_real, open_synth = lip_opening(real), lip_opening(synthesized)
    width_real, width_synth = mouth_width(real), mouth_width(synthesized)
    spoken = np.arange(len(real))[speech]
    per_frame = {
        "mouth_lmd": lmd,
        "lip_opening_real": open_real,
        "lip_opening_synth": open_synth,
        "mouth_width_real": width_real,
        "mouth_width_synth": width_synth,
    }
    real_sd = open_real[spoken].std() if len(spoken) else 0.0
    summary = {
        "mouth_lmd": float(lmd.mean()),
        "mouth_lmd_speech": float(lmd[spoken].mean()) if len(spoken) else float("nan"),
        "lip_opening_corr_speech": correlation(open_synth[spoken], open_real[spoken]),
        "lip_opening_amplitude_speech": float(open_synth[spoken].std() / real_sd)
        if real_sd > 0
        else float("nan"),
        "mouth_width_corr_speech": correlation(width_synth[spoken], width_real[spoken]),
        "lip_opening_corr": correlation(open_synth, open_real),
        "lip_opening_lag": float(lag_frames(open_synth, open_real, max_lag=max_lag))
        if _varies(open_synth) and _varies(open_real)
        else float("nan"),
    }
    return per_frame, summary


def _varies(signal: np.ndarray) -> bool:
    """Whether a signal changes (beyond floating-point wobble), as :func:`correlation` judges."""
    return correlation(signal, signal) != 0.0


def paired_differences(
    table: pd.DataFrame,
    *,
    reference: tuple[str, str],
    measures: Sequence[str] = LANDMARK_MEASURES,
) -> pd.DataFrame:
    """Each renderer minus the reference on the same clips: mean and spread over clips.

    Parameters
    ----------
    table : DataFrame
        Per-clip rows with ``clip``, ``renderer``, ``model`` and the measures.
    reference : (renderer, model)
        The row every other is paired with (the paper's morph of the face's
        own model).
    measures : sequence of str
        The measures paired (those ``table`` lacks are skipped).

    Returns
    -------
    DataFrame
        One row per ``(renderer, model)`` with ``<measure>_vs_<renderer>_mean``
        and ``_sd`` (the standard deviation of the clip-by-clip difference);
        no columns when the table has no reference rows.
    """
    renderer, model = reference
    present = [m for m in measures if m in table.columns]
    base = table[(table["renderer"] == renderer) & (table["model"] == model)]
    if base.empty or not present:
        return pd.DataFrame(index=pd.MultiIndex.from_tuples([], names=["renderer", "model"]))
    paired = table[["clip", "renderer", "model", *present]].merge(
        base[["clip", *present]], on="clip", how="inner", suffixes=("", "_reference")
    )
    diffs = pd.DataFrame(
        paired[present].to_numpy(float)
        - paired[[f"{m}_reference" for m in present]].to_numpy(float),
        columns=present,
    )
    diffs["renderer"], diffs["model"] = paired["renderer"], paired["model"]
    grouped = diffs.groupby(["renderer", "model"], sort=False)[present]
    suffix = f"_vs_{renderer}"
    mean = grouped.mean().add_suffix(f"{suffix}_mean")
    spread = grouped.std(ddof=1).add_suffix(f"{suffix}_sd")
    return pd.concat([mean, spread], axis=1)
