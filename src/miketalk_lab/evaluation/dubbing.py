"""Dubbing measured: each held-out clip dubbed with its own audio and compared with its real video.

The clip's own frames are the background
(:func:`miketalk.composite.background.background_from_video`,
registered to the model's reference), the model renders the mouth from the
clip's own aligned phones at its own frame rate, and the render is composited
into every frame (:class:`miketalk.composite.compositor.Compositor`). So dubbed
frame ``k`` and real frame ``k`` show the same moment and differ only where
the mouth was blended in. Measures (:func:`dub_measures`):

``psnr_frame``
    PSNR of the whole frame (the mean squared error over all frames);
``seam_ratio``
    the mean gradient magnitude (Sobel, luma) along the blend border (the
    pixels where the placed blend mask is between 0.25 and 0.75) in the
    dubbed frames, over the same in the real frames: 1 is a border no one can
    find by its edges, above 1 a visible seam;
``nose_jitter``
    RMS over consecutive frames of the nose's motion in the stabilized real
    frames (DIS flow over the band between the eyes and the mouth): the
    composited mouth is fixed in the reference's coordinates, so this is how
    much the nose moves against it that the real mouth would have followed
    (the stabilization's frame-to-frame error);
``jitter_*``, ``upper_jitter_*``
    the mouth's frame-to-frame motion against the nose from dlib's landmarks on
    the frames as seen (:func:`jitter_measures`), real, dubbed and dubbed beyond
    real (``jitter_beyond``: the issue's target, at most 0.3 px RMS);
the held-out mouth measures (:func:`miketalk_lab.evaluation.heldout.compare`) on
the dubbed frames brought back onto the reference (``dub``) beside the same
render uncomposited (``render``);
``roundtrip_sharpness_ratio``, ``roundtrip_psnr_mouth``
    the calibration (:func:`roundtrip_measures`): the clip's own frames,
    stabilized onto the reference, dubbed back in as a perfect render and
    measured as the dub is. What compositing and the measure's own resampling
    cost a mouth that is right: the ceiling of ``dub_sharpness_ratio`` and
    ``dub_psnr_mouth``.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import cv2
import numpy as np

from miketalk import defaults
from miketalk.errors import MiketalkError

__all__ = [
    "DubbedClip",
    "dub_clip",
    "dub_measures",
    "jitter_measures",
    "nose_jitter",
    "psnr_frames",
    "roundtrip_measures",
    "seam_ratio",
    "seam_sums",
]


@dataclass(frozen=True)
class DubbedClip:
    """A held-out clip dubbed with its own audio.

    Attributes
    ----------
    real : numpy.ndarray
        (N, H, W, 3) the clip's frames as recorded.
    dubbed : numpy.ndarray
        (N, H, W, 3) the same with the synthesized mouth composited in.
    renders : numpy.ndarray
        (N, h, w, 3) the model's frames (reference coordinates).
    alphas : numpy.ndarray
        (N, H, W) float32 the blend mask as placed in each frame.
    background : miketalk.composite.background.Background
        The clip's frames with their transforms and conform field.
    """

    real: np.ndarray
    dubbed: np.ndarray
    renders: np.ndarray
    alphas: np.ndarray
    background: object


def dub_clip(
    frames: np.ndarray,
    fps: float,
    renders: np.ndarray,
    *,
    stabilizer,
    compositor,
    rest: np.ndarray | None = None,
    smooth: float = defaults.BACKGROUND_SMOOTH,
) -> DubbedClip:
    """Composite ``renders`` into the clip's own ``frames`` (see the module docstring).

    ``rest`` (the model's silence image) matches the mouth's colour once for
    the clip; without it, frame by frame. ``smooth``: the transforms' smoothing in time,
    seconds (:func:`~miketalk.composite.background.background_from_video`; 0: raw).
    """
    from miketalk.composite.background import background_from_video, composited

    if len(frames) != len(renders):
        raise MiketalkError(f"{len(renders)} renders for {len(frames)} frames")
    background = background_from_video(frames, fps, stabilizer, source="the clip", smooth=smooth)
    dubbed = np.stack(list(composited(renders, background, compositor, fps=fps, rest=rest)))
    alphas = np.stack(
        [
            compositor.place(t, frames.shape[1:3], field=background.field).full_alpha(
                frames.shape[1:3]
            )
            for t in background.transforms
        ]
    )
    return DubbedClip(frames, dubbed, renders, alphas, background)


def psnr_frames(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR (dB) of the mean squared error over every pixel of every frame."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else float(10 * np.log10(255.0**2 / mse))


def _gradient(frame: np.ndarray) -> np.ndarray:
    grey = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY).astype(np.float32)
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3)
    return np.sqrt(gx * gx + gy * gy)


def seam_sums(dubbed: np.ndarray, real: np.ndarray, alpha: np.ndarray) -> tuple[float, float]:
    """One frame's summed gradient magnitude on the blend border (``alpha`` between 0.25 and
    0.75), dubbed and real: :func:`seam_ratio`'s numerator and denominator, frame by frame."""
    border = (alpha > 0.25) & (alpha < 0.75)
    return float(_gradient(dubbed)[border].sum()), float(_gradient(real)[border].sum())


def seam_ratio(dubbed: np.ndarray, real: np.ndarray, alphas: np.ndarray) -> float:
    """Mean gradient magnitude on the blend border, dubbed over real (see the module docstring)."""
    num = den = 0.0
    for d, r, a in zip(dubbed, real, alphas, strict=True):
        n, m = seam_sums(d, r, a)
        num += n
        den += m
    return num / den if den > 0 else float("nan")


def nose_jitter(stabilized: np.ndarray, mouth_box: tuple[int, int, int, int]) -> float:
    """RMS frame-to-frame motion (px) of the nose band in stabilized frames."""
    x, y, w, _ = mouth_box
    cx = x + w / 2
    top, bottom = max(0, round(y - 0.8 * w)), max(1, round(y - 0.15 * w))
    left, right = max(0, round(cx - 0.8 * w)), round(cx + 0.8 * w)
    dis = cv2.DISOpticalFlow_create(cv2.DISOpticalFlow_PRESET_MEDIUM)
    grey = [cv2.cvtColor(f, cv2.COLOR_RGB2GRAY) for f in stabilized]
    moves = []
    for a, b in pairwise(grey):
        flow = dis.calc(a, b, None)[top:bottom, left:right].reshape(-1, 2)
        moves.append(np.median(flow, axis=0))
    m = np.asarray(moves)
    return float(np.sqrt(np.mean((m * m).sum(axis=1)))) if len(m) else 0.0


def dub_measures(
    dubbed: DubbedClip,
    *,
    stabilizer,
    mouth_box,
    eigenlips,
    speech=None,
    landmarks=None,
    compositor=None,
) -> tuple[dict, dict, dict]:
    """Whole-frame and seam measures, and the mouth measures of the dub and of the render.

    Parameters
    ----------
    landmarks : miketalk_lab.evaluation.landmarks.FaceLandmarks, optional
        With it, the landmark measures too (``mouth_lmd``, ``lip_opening_corr_speech``, ...:
        :func:`miketalk_lab.evaluation.landmark_scores.landmark_scores`), the dub and the render
        each against the real frames, all stabilized onto the reference and marked from the
        real frames' one face box.
    compositor : miketalk.composite.compositor.Compositor, optional
        The one that made the dub: with it, the frame measures also hold the dub's ceiling
        (:func:`roundtrip_measures`).

    Returns
    -------
    (frame_measures, dub_mouth, render_mouth)
        ``psnr_frame``, ``seam_ratio``, ``nose_jitter`` (and ``roundtrip_*``); then the summaries of
        :func:`miketalk_lab.evaluation.heldout.compare` for the dubbed frames
        stabilized onto the reference and for the uncomposited render.
    """
    from miketalk_lab.evaluation.heldout import MAX_LAG, compare
    from miketalk_lab.evaluation.landmark_scores import ClipLandmarks, landmark_scores

    bg = dubbed.background
    real_steady = stabilizer.apply(dubbed.real, bg.transforms, field=bg.field)
    dub_steady = stabilizer.apply(dubbed.dubbed, bg.transforms, field=bg.field)
    frame = {
        "psnr_frame": psnr_frames(dubbed.dubbed, dubbed.real),
        "seam_ratio": seam_ratio(dubbed.dubbed, dubbed.real, dubbed.alphas),
        "nose_jitter": nose_jitter(real_steady, stabilizer.mouth_box),
    }
    if compositor is not None:
        frame |= roundtrip_measures(
            dubbed, real_steady, stabilizer=stabilizer, compositor=compositor, mouth_box=mouth_box
        )
    dub = compare(real_steady, dub_steady, mouth_box=mouth_box, eigenlips=eigenlips, speech=speech)
    render = compare(
        real_steady, dubbed.renders, mouth_box=mouth_box, eigenlips=eigenlips, speech=speech
    )
    if landmarks is None:
        return frame, dub.summary, render.summary
    marks = ClipLandmarks(landmarks, real_steady)
    spoken = speech if speech is not None else slice(None)
    dub_points, render_points = marks.of(dub_steady), marks.of(dubbed.renders)
    seen = ClipLandmarks(landmarks, dubbed.real)  # as a viewer sees them: one box, the head moves
    frame |= jitter_measures(seen.real, seen.of(dubbed.dubbed), render_points)
    _, dub_marks = landmark_scores(marks.real, dub_points, speech=spoken, max_lag=MAX_LAG)
    _, render_marks = landmark_scores(marks.real, render_points, speech=spoken, max_lag=MAX_LAG)
    return frame, dub.summary | dub_marks, render.summary | render_marks


def roundtrip_measures(
    dubbed: DubbedClip, real_steady: np.ndarray, *, stabilizer, compositor, mouth_box
) -> dict:
    """The dub's ceiling: the real frames, stabilized, composited back and measured as the dub.

    Each real frame brought onto the reference (``real_steady``, as :func:`dub_measures`
    stabilizes them) is the render of its own frame (no colour match: it has its own light),
    and the result is brought onto the reference again, as :func:`dub_measures` does with the
    dub. A dub whose mouth were exactly the real one would score these.

    Returns
    -------
    dict
        ``roundtrip_sharpness_ratio`` (its mouth's sharpness over the real one's) and
        ``roundtrip_psnr_mouth`` (dB, over the mouth box; ``inf`` for identical pixels).
    """
    from miketalk_lab.evaluation.measures import box_mask, psnr, sharpness_ratio

    bg = dubbed.background
    zero = np.zeros((*real_steady.shape[1:3], 3), np.float32)
    back = np.stack(
        [
            compositor(frame, steady, t, field=bg.field, offset=zero)
            for frame, steady, t in zip(dubbed.real, real_steady, bg.transforms, strict=True)
        ]
    )
    back_steady = stabilizer.apply(back, bg.transforms, field=bg.field)
    mask = box_mask(real_steady.shape[1:], mouth_box)
    return {
        "roundtrip_sharpness_ratio": sharpness_ratio(back_steady, real_steady, mask),
        "roundtrip_psnr_mouth": float(psnr(back_steady[:, mask], real_steady[:, mask])),
    }


def jitter_measures(real: np.ndarray, dub: np.ndarray, render: np.ndarray) -> dict:
    """The mouth's frame-to-frame motion against the nose, dubbed beyond real (landmarks).

    Parameters
    ----------
    real, dub : (N, 68, 2) array
        Landmarks of the real and the dubbed frames as a viewer sees them (not stabilized:
        the head moves, the mouth-to-nose offset cancels it).
    render : (N, 68, 2) array
        Landmarks of the uncomposited render (the reference's coordinates).

    Returns
    -------
    dict
        ``jitter_real``, ``jitter_dub``, ``jitter_render`` (px RMS,
        :func:`miketalk_lab.evaluation.landmarks.mouth_nose_jitter` of the 20 mouth points)
        and ``jitter_beyond`` (dub minus real: the issue's target, at most 0.3 px); the
        same of the upper lip alone (``upper_jitter_*``), which the jaw moves least. Both
        include articulation, and the synthesized mouth moves less than his (its opening's
        amplitude is smaller), so ``jitter_beyond`` can fall below 0 while the mouth still
        slides against the nose; the slide alone is ``nose_jitter`` (the registration's
        frame-to-frame error, :func:`nose_jitter`).
    """
    from miketalk_lab.evaluation.landmarks import MOUTH, UPPER_LIP, mouth_nose_jitter

    out = {}
    for prefix, part in (("jitter", MOUTH), ("upper_jitter", UPPER_LIP)):
        values = {k: mouth_nose_jitter(p, part) for k, p in (("real", real), ("dub", dub),
                                                               ("render", render))}  # fmt: skip
        out |= {f"{prefix}_{k}": v for k, v in values.items()}
        out[f"{prefix}_beyond"] = values["dub"] - values["real"]
    return out
