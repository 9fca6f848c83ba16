"""A face-crop dub's ceiling, and the jaw's warp kept inside the face.

The held-out dub of a face-crop model (:mod:`miketalk_lab.evaluation.dub_crop`) keeps 0.93
to 0.94 of the render's lip-opening amplitude. Part of that may be the measure's own: the dub
is resampled into the frames, encoded, tracked and resampled again into the corpus's crop,
where the render is read as drawn. The ceiling (:func:`roundtrip_frames`) runs the clip's own
frames through the same path: each real frame brought onto the reference through the
background's own transform (:func:`real_in_reference`, the "render" a perfect model would
draw, read by the measure as the render is) and pasted back into its frame by the product's
compositor (same transform, mask, bicubic sampling, jaw warp; no colour offset, it has its own
light), then encoded and read back as the dub is. Its amplitude over the real-in-reference's
is the most the dub's ``amplitude_kept`` can score.

The jaw's warp (``follow``, :func:`~miketalk.composite.follow.follow_render`) moves the
frame's pixels up to half a mouth width beyond the blend mask; a crop model's mask stops at
the jaw line, so on a textured room the lines beside the jaw bend. :data:`FOLLOWS` are the
ways a crop model's compositor may warp (:func:`crop_compositor`): ``on`` (everywhere its
weight reaches, as before), ``face`` (held inside the crop's keep: its jaw ellipse and skin,
:attr:`~miketalk.composite.compositor.Compositor.follow_within`), ``off``.
"""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from miketalk.errors import MiketalkError

__all__ = [
    "FOLLOWS",
    "crop_compositor",
    "crop_keep",
    "pasted",
    "read_back_all",
    "real_in_reference",
    "roundtrip_frames",
]

#: How a crop model's compositor may warp the frame's jaw (see the module docstring).
FOLLOWS = ("on", "face", "off")


def crop_keep(model) -> np.ndarray:
    """The crop model's keep: its reference's skin times the crop's jaw ellipse, (H, W) float32
    (what :func:`~miketalk.composite.for_model.model_compositor` multiplies into the
    blend mask) of the :class:`~miketalk.model.face.Model` ``model``."""
    from miketalk.composite.follow import skin_weight
    from miketalk.track.crop import jaw_mask

    crop = model.crop
    if crop is None:
        raise MiketalkError(f"{model.directory} is not a face-crop model")
    return skin_weight(model.reference, model.face_mask) * jaw_mask(crop)


def crop_compositor(model, size: tuple[int, int], follow: str):
    """The product's compositor of a crop model (a :class:`~miketalk.model.face.Model`) with
    the jaw's warp ``follow`` (:data:`FOLLOWS`)."""
    from miketalk.composite.for_model import model_compositor

    if follow not in FOLLOWS:
        raise MiketalkError(f"follow must be one of {', '.join(FOLLOWS)}, not {follow!r}")
    if follow == "off":
        return model_compositor(model, size, follow=False)
    if follow == "on":
        return model_compositor(model, size, follow=True, follow_within=None)
    return model_compositor(model, size, follow=True, follow_within=crop_keep(model))


def real_in_reference(dub, size: tuple[int, int]) -> np.ndarray:
    """Each real frame the dub was pasted into, brought onto the reference through its own
    transform and the clip's conform field (linear, as a stabilizer samples): ``(N, H, W, 3)``
    uint8, the render a perfect model would have drawn."""
    bg = dub.background
    h, w = size
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    if bg.field is not None:
        xx, yy = xx + bg.field[..., 0], yy + bg.field[..., 1]
    out = np.empty((len(dub.source), h, w, 3), np.uint8)
    for k, frame in enumerate(dub.source):
        t = bg.transforms[bg.index(k, dub.fps)].astype(np.float32)
        mx = t[0, 0] * xx + t[0, 1] * yy + t[0, 2]
        my = t[1, 0] * xx + t[1, 1] * yy + t[1, 2]
        out[k] = cv2.remap(frame, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out


def roundtrip_frames(dub, steady: np.ndarray, compositor) -> np.ndarray:
    """The real frames pasted back into themselves (:func:`real_in_reference`'s ``steady``
    as the render, no colour offset) where the dub placed a mouth: ``(N, H', W', 3)``."""
    bg = dub.background
    zero = np.zeros((*steady.shape[1:3], 3), np.float32)
    out = np.array(dub.source, copy=True)
    for k, frame in enumerate(dub.source):
        if dub.boxes[k] is None:
            continue
        out[k] = compositor(frame, steady[k], bg.transforms[bg.index(k, dub.fps)],
                            field=bg.field, offset=zero)  # fmt: skip
    return out


def pasted(dub, model, compositor) -> np.ndarray:
    """The dub's renders pasted back by ``compositor`` as the product pastes them
    (:func:`~miketalk.composite.background.composited`, the colour matched once from the
    model's silence image): ``(N, H', W', 3)``."""
    from miketalk.composite.background import composited
    from miketalk.visemes import SILENCE

    rest = model.image(SILENCE) if SILENCE in model.visemes else None
    return np.stack(list(composited(dub.renders, dub.background, compositor, fps=dub.fps,
                                    rest=rest)))  # fmt: skip


def read_back_all(clip, videos: dict, *, decode, stabilizer, table):
    """The real clip and several mp4s of it (``{name: (video, timings)}``), each read as a crop
    model's test clip is (:func:`~miketalk_lab.evaluation.dub_crop.read_back`), on the frames
    all of them kept.

    Returns
    -------
    (real, read, lo, speech)
        The real crops, ``{name: crops}``, the clip's first frame among them (renders
        ``[lo:lo + len(real)]`` are theirs) and the speech's frames (a slice).
    """
    from miketalk.corpus.steady import stabilize_clip
    from miketalk.lipsync.timeline import plan
    from miketalk_lab.evaluation.dub_crop import _offset
    from miketalk_lab.evaluation.heldout import speech_frames

    real_decoded, real = stabilize_clip(decode(clip), stabilizer)
    at_real = _offset(real_decoded, clip)
    kept = {}
    for name, (video, timings) in videos.items():
        other = replace(clip, media=video, timings=timings, span=None, fps=None)
        decoded, frames = stabilize_clip(decode(other), stabilizer)
        kept[name] = (_offset(decoded, other), frames.frames)
    fps = real_decoded.fps
    timeline = plan(real_decoded.phones, table, fps=fps, duration=len(real.frames) / fps)
    speech = speech_frames(timeline)
    lo = max([at_real, 0, *(a for a, _ in kept.values())])
    hi = min([at_real + len(real.frames), *(a + len(f) for a, f in kept.values())])
    if hi - lo < 3:
        raise MiketalkError(f"clip {clip.id}: the mp4s and the clip share {hi - lo} frames")
    start = min(max(0, speech.start + at_real - lo), hi - lo)
    stop = min(max(0, speech.stop + at_real - lo), hi - lo)
    read = {name: f[lo - a : hi - a] for name, (a, f) in kept.items()}
    return real.frames[lo - at_real : hi - at_real], read, lo, slice(start, max(start, stop))
