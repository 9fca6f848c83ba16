"""Held-out clips of a face-crop model dubbed as ``miketalk dub --audio`` dubs them, measured.

A model built in the face's canonical crop renders the mouth in crop pixels and pastes it
back into every full-resolution frame through the inverse of that frame's transform. Each
held-out clip is dubbed with its own audio and its known word timings by the product's own
path (:func:`dub_through_product`: :func:`~miketalk.composite.for_model.
video_background` and :func:`~miketalk.talk.say.say` with a
:class:`~miketalk.talk.say.Recorded`, what ``miketalk dub CLIP --audio CLIP --timings
ALIGN`` runs), and measured two ways:

at full resolution (:func:`paste_measures`), the frames the product encoded against the
clip's frames they were pasted into:

``seam_ratio``
    the mean gradient magnitude on the blend's edge (the placed mask between 0.25 and 0.75),
    dubbed over real (:func:`~miketalk_lab.evaluation.dubbing.seam_sums`): 1 is an edge no
    one can find, above 1 a visible seam;
``psnr_frame``, ``psnr_outside``
    PSNR of the whole frames, and of their pixels outside the placed blend mask (alpha 0:
    what the paste-back must leave as it was; the jaw's warp, ``follow``, may touch them
    near the mask);
``identical_share``, ``identical_outside_box``
    the share of the frames' pixels (all three channels) bit-identical to the clip's, in the
    whole frame and outside the box the compositor may touch (which must be 1);
``moved_outside_px``
    pixels per frame outside the placed blend mask changed by more than
    :data:`MOVED_LEVELS`: the jaw's warp (``follow``) beside the mask, which bends what is
    behind the jaw (a textured room's lines) where no seam ratio looks;
``psnr_encoded``
    PSNR of the product's mp4 as decoded against the frames it encoded (what H.264 costs);

and in the corpus's crop pixels (:func:`read_back`), the real clip and the product's mp4
each read as the held-out evaluation reads a crop model's test clip (tracked and cropped
with the corpus's crop, :func:`~miketalk.corpus.clips.corpus_decoder`, registered to the
corpus's reference, :func:`~miketalk.corpus.steady.stabilize_clip`), beside the same
render before paste-back: the held-out mouth measures
(:func:`~miketalk_lab.evaluation.heldout.compare`) and dlib's landmark measures
(lip opening r and amplitude over the speech, mouth LMD), ``dub_*`` and ``render_*``, each
against the real frames.
"""

from __future__ import annotations

import logging
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

log = logging.getLogger(__name__)

__all__ = [
    "CropDub",
    "dub_through_product",
    "lipsync_of",
    "mouth_span",
    "paste_measures",
    "read_back",
    "shared_frames",
    "side_by_side_frames",
    "work_folder",
]

#: A pixel outside the blend mask changed by more than this (of 255, in any channel) was
#: moved by the jaw's warp, not by rounding (:func:`paste_measures`).
MOVED_LEVELS = 8

#: The held-out renderer's lip-sync model and trajectory in ``miketalk dub``'s options
#: (None: the trained face's own default trajectory).
LIPSYNC_OF = {
    "morph": ("paper", None),
    "learned": ("learned", None),
    "trained": ("trained", None),
    "trained_heard": ("trained", "heard"),
}


def lipsync_of(renderer: str, model_dir: str | Path) -> tuple[str, str | None]:
    """``(lipsync_model, trajectory)`` of ``miketalk dub`` that draws as ``renderer`` does
    (:data:`LIPSYNC_OF`; ``trained`` takes the trained face's default trajectory, which a
    recording would otherwise replace by ``heard``).

    Raises
    ------
    MiketalkError
        For a renderer ``dub`` does not draw with.
    """
    if renderer not in LIPSYNC_OF:
        raise MiketalkError(f"cannot dub with {renderer!r} (known: {', '.join(LIPSYNC_OF)})")
    model, trajectory = LIPSYNC_OF[renderer]
    if renderer == "trained":
        from miketalk.model.parts import trained_default

        trajectory = trained_default(model_dir)
    return model, trajectory


@dataclass(frozen=True)
class CropDub:
    """One clip dubbed through the product.

    Attributes
    ----------
    video : Path
        The product's mp4 (the dubbed frames at full resolution, the clip's sound).
    timings : Path or None
        The word timings the product was given (and the dub is read back with).
    frames : numpy.ndarray
        (N, H, W, 3) the full-resolution frames the product encoded.
    source : numpy.ndarray
        (N, H, W, 3) the clip's frames each was pasted into.
    renders : numpy.ndarray
        (N, h, w, 3) the same render before paste-back (crop pixels).
    boxes : list
        Per frame the placed blend's box ``(x0, y0, x1, y1)`` (None: nothing placed).
    alphas : list
        Per frame the placed blend mask over the box (None: nothing placed).
    fps : float
        The clip's frame rate.
    seconds : float
        The product's dub (registration, alignment, render, paste-back, encoding), wall.
    background : Background or None
        What the renders were pasted into (its transforms, field and frames).
    """

    video: Path
    timings: Path | None
    frames: np.ndarray
    source: np.ndarray
    renders: np.ndarray
    boxes: list
    alphas: list
    fps: float
    seconds: float
    background: object = None


def _product_inputs(clip, work: Path) -> tuple[Path, Path | None, str | None, dict]:
    """What ``miketalk dub`` is given for ``clip``: the recording, its word timings (or None
    and the text), and the part of the video (``{}``: the whole file). A clip cut from one
    video (its ``span``) has its sound written to a wav and its words to a GRID ``.align``."""
    if clip.span is None:
        return Path(clip.media), clip.timings, None if clip.timings else clip.text, {}
    from miketalk.corpus.clip_sources import RATE
    from miketalk.media.audio import write_wav
    from miketalk.media.decode import read_media_audio

    seconds = clip.span[1] / clip.fps
    audio = work / f"{clip.id}.wav"
    write_wav(audio, read_media_audio(clip.media, rate=RATE, start=clip.start,
                                      duration=seconds), RATE)  # fmt: skip
    timings = None
    if clip.given_words is not None:
        timings = work / f"{clip.id}.align"
        units = 25000  # GRID's
        timings.write_text(
            "".join(f"{round(w.start * units)} {round(w.end * units)} {w.word}\n"
                    for w in clip.given_words), "utf-8",
        )  # fmt: skip
    return audio, timings, None if timings else clip.text, {"start": clip.start,
                                                            "frames": clip.span[1]}  # fmt: skip


def dub_through_product(clip, *, model, lipsync: tuple[str, str | None], work: Path) -> CropDub:
    """Dub ``clip`` with its own audio as ``miketalk dub`` does; keep what it encoded.

    The background is :func:`~miketalk.composite.for_model.video_background` of the
    clip's video (a clip cut from one video: :func:`~miketalk.composite.tracked.
    tracked_background` of its part, which ``video_background`` calls for a whole file),
    the mp4 :func:`~miketalk.talk.say.say`'s of a :class:`~miketalk.talk.say.Recorded` with
    the clip's word timings, at the clip's frame rate, with ``dub``'s other defaults. The
    render before paste-back is drawn again along the timeline the product wrote (drawing is
    deterministic) and pasted back as the product does
    (:func:`~miketalk.composite.for_model.composite_renders`): the frames it encoded.
    """
    from miketalk.composite.for_model import (
        composite_renders,
        model_compositor,
        video_background,
    )
    from miketalk.composite.tracked import tracked_background
    from miketalk.corpus.clip_sources import RATE
    from miketalk.lipsync.settings import LipsyncSettings
    from miketalk.media.decode import read_media_audio, video_info
    from miketalk.speech.acoustic import Recording
    from miketalk.talk.say import Recorded, say

    audio, timings, text, part = _product_inputs(clip, work)
    fps = video_info(clip.media)[2]
    settings = LipsyncSettings(fps=fps, model=lipsync[0], trajectory=lipsync[1])
    video = work / f"{clip.id}.mp4"
    started = time.perf_counter()
    if part:
        background = tracked_background(
            clip.media, model.stabilizer(), model.crop, source=f"clip {clip.id}", **part
        )
    else:
        background = video_background(model, clip.media)
    spoken = say(Recorded(audio, text=text, timings=timings), video, model=model,
                 settings=settings, background=background, overwrite=True)  # fmt: skip
    seconds = time.perf_counter() - started
    drawing = model.drawing(settings.model, trajectory=settings.trajectory, recorded=True)
    recording = Recording(read_media_audio(audio, rate=RATE), RATE)
    drawn, _, _ = drawing.frames(model, spoken.timeline, recording=recording,
                                 max_px_per_frame=settings.max_px_per_frame)  # fmt: skip
    renders = np.stack(list(drawn))
    frames = np.stack(list(composite_renders(renders, background, model, fps=fps)))
    compositor = model_compositor(model, model.size)
    shape = background.size
    source, boxes, alphas = [], [], []
    for k in range(len(frames)):
        i = background.index(k, fps)
        source.append(np.asarray(background.frames[i], np.uint8))
        shown = background.shown is None or background.shown[i]
        placed = compositor.place(background.transforms[i], shape, field=background.field)
        placed = placed if shown else None
        boxes.append(None if placed is None else placed.box)
        alphas.append(None if placed is None else placed.alpha)
    return CropDub(video, timings, frames, np.stack(source), renders, boxes, alphas, fps,
                   seconds, background)  # fmt: skip


def paste_measures(dub: CropDub) -> dict:
    """The full-resolution measures of a dub (see the module docstring), frame by frame (a
    720p clip's frames in floating point would take gigabytes)."""
    from miketalk.media.decode import iter_video_frames
    from miketalk_lab.evaluation.dubbing import seam_sums

    num = den = 0.0
    err = err_outside = n_outside = same = same_outside = outside_box = moved = 0.0
    for frame, src, box, alpha in zip(dub.frames, dub.source, dub.boxes, dub.alphas,
                                      strict=True):  # fmt: skip
        full = np.zeros(frame.shape[:2], np.float32)
        inside = np.zeros(frame.shape[:2], bool)
        if box is not None:
            x0, y0, x1, y1 = box
            full[y0:y1, x0:x1] = alpha
            inside[y0:y1, x0:x1] = True
        n, d = seam_sums(frame, src, full)
        num, den = num + n, den + d
        diff = frame.astype(np.float64) - src.astype(np.float64)
        err += float(np.sum(diff * diff))
        out = full == 0
        err_outside += float(np.sum(diff[out] ** 2))
        n_outside += float(out.sum()) * 3
        moved += float((out & (np.abs(diff).max(axis=2) > MOVED_LEVELS)).sum())
        equal = np.all(frame == src, axis=2)
        same += float(equal.sum())
        same_outside += float(equal[~inside].sum())
        outside_box += float((~inside).sum())
    encoded = n_encoded = 0.0
    for k, frame in enumerate(iter_video_frames(dub.video, frames=len(dub.frames))):
        diff = frame.astype(np.float64) - dub.frames[k].astype(np.float64)
        encoded += float(np.sum(diff * diff))
        n_encoded += diff.size
    pixels = dub.frames.shape[0] * dub.frames.shape[1] * dub.frames.shape[2]
    return {
        "seam_ratio": num / den if den > 0 else float("nan"),
        "psnr_frame": _psnr(err, pixels * 3),
        "psnr_outside": _psnr(err_outside, n_outside),
        "identical_share": same / pixels,
        "identical_outside_box": same_outside / outside_box if outside_box else float("nan"),
        "moved_outside_px": moved / len(dub.frames),
        "psnr_encoded": _psnr(encoded, n_encoded),
    }


def _psnr(squared: float, count: float) -> float:
    """PSNR (dB) of a summed squared error over ``count`` values (inf when none differ)."""
    if count == 0 or squared == 0:
        return float("inf")
    return float(10 * np.log10(255.0**2 / (squared / count)))


def _offset(decoded, clip) -> int:
    """The first frame of ``clip`` that :func:`~miketalk.corpus.steady.stabilize_clip` kept."""
    first = decoded.clip.span[0] if decoded.clip.span is not None else 0
    return first - (clip.span[0] if clip.span is not None else 0)


def read_back(clip, dub: CropDub, *, decode, stabilizer, table):
    """The real clip and the product's mp4, read as a crop model's test clip is, beside the
    render: the frames all three share.

    Returns
    -------
    (real, dubbed, rendered, speech)
        ``(n, s, s, 3)`` stabilized crops of the real clip and of the dub, the renders of
        the same frames, and the speech's frames among them (a slice).

    Raises
    ------
    ClipError
        When either does not register in its speech (the clip is then left out).
    """
    from dataclasses import replace

    from miketalk.corpus.steady import stabilize_clip
    from miketalk.lipsync.timeline import plan
    from miketalk_lab.evaluation.heldout import speech_frames

    real_decoded, real = stabilize_clip(decode(clip), stabilizer)
    dubbed_clip = replace(clip, media=dub.video, timings=dub.timings, span=None, fps=None)
    dub_decoded, dubbed = stabilize_clip(decode(dubbed_clip), stabilizer)
    at_real, at_dub = _offset(real_decoded, clip), _offset(dub_decoded, dubbed_clip)
    fps = real_decoded.fps
    timeline = plan(real_decoded.phones, table, fps=fps, duration=len(real.frames) / fps)
    lo, hi, speech = shared_frames(
        (at_real, len(real.frames)), (at_dub, len(dubbed.frames)), len(dub.renders),
        speech_frames(timeline),
    )  # fmt: skip
    if hi - lo < 3:
        raise MiketalkError(f"clip {clip.id}: the dub and the clip share {hi - lo} frames")
    return (
        real.frames[lo - at_real : hi - at_real],
        dubbed.frames[lo - at_dub : hi - at_dub],
        dub.renders[lo:hi],
        speech,
    )


def shared_frames(
    real: tuple[int, int], dubbed: tuple[int, int], renders: int, speech: slice
) -> tuple[int, int, slice]:
    """The clip's frames ``lo`` to ``hi`` that the real clip and the dub both kept after
    registration (each ``(first kept, count)``) and the renders cover, and the speech
    (``speech``, in the real clip's kept frames) among them.

    Returns
    -------
    (lo, hi, speech)
        ``hi <= lo`` when they share none.
    """
    lo = max(real[0], dubbed[0], 0)
    hi = min(real[0] + real[1], dubbed[0] + dubbed[1], renders)
    start = min(max(0, speech.start + real[0] - lo), max(0, hi - lo))
    stop = min(max(0, speech.stop + real[0] - lo), max(0, hi - lo))
    return lo, hi, slice(start, max(start, stop))


def side_by_side_frames(dub: CropDub):
    """The clip's frames | the dubbed ones, frame by frame (for the mp4, streamed)."""
    for real, dubbed in zip(dub.source, dub.frames, strict=True):
        yield np.concatenate([real, dubbed], axis=1)


def mouth_span(dub: CropDub, frames: int) -> tuple[int, int, int, int] | None:
    """``(x, y, w, h)`` holding the placed blend's box in the first ``frames`` frames (the
    strip's mouth row: the head moves, the box with it)."""
    boxes = np.array([b for b in dub.boxes[:frames] if b is not None])
    if not len(boxes):
        return None
    x0, y0 = boxes[:, :2].min(axis=0)
    x1, y1 = boxes[:, 2:].max(axis=0)
    return int(x0), int(y0), int(x1 - x0), int(y1 - y0)


def work_folder() -> tempfile.TemporaryDirectory:
    """Where the product's mp4s are written while a clip is measured (removed after)."""
    return tempfile.TemporaryDirectory(prefix="miketalk-dub-crop-")
