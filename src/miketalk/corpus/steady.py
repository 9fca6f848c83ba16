"""A decoded clip stabilized, less the frames around its speech that do not register.

Some recordings open or close on frames nobody can register: four of GRID s1's
200 clips (bbizzn, brwg8p, lgbf8n, prii9a) begin with 12 frames of plain grey
and half-drawn blocks (their MPEG streams start between key frames), and an
utterance cut from one long video can hold a cut to another shot in its pause.
One such frame used to cost the whole clip. Now the frames before the clip's
first spoken phone and after its last one that do not register are left out,
with everything on their side of them, and the sound, phones and words are cut
to match (:meth:`~miketalk.corpus.clip_sources.DecodedClip.cut`). A frame in
the speech that does not register still costs the clip: the speech is what the
corpus is for, and a hole in it would tear the timing. (A frame the face tracker left out
in the speech has already cut the utterance at its words, :mod:`miketalk.corpus.pieces`:
what still reaches here is an utterance of which no piece is kept, or a frame the
registration refuses.)
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from miketalk.corpus.clip_sources import ClipError, DecodedClip
from miketalk.speech.types import Phone
from miketalk.track.refine import refine_crops

log = logging.getLogger(__name__)


def speech_span(phones: Sequence[Phone], fps: float, n_frames: int) -> tuple[int, int]:
    """The frames ``[first, stop)`` that show any of the spoken phones (not ``pau``).

    All ``n_frames`` when no phone is spoken.
    """
    spoken = [p for p in phones if p.name != "pau"]
    if not spoken:
        return 0, n_frames
    first = int(np.floor(spoken[0].start * fps + 1e-6))
    stop = int(np.ceil(spoken[-1].end * fps - 1e-6))
    return max(0, first), min(n_frames, max(stop, first + 1))


def kept_frames(failed: np.ndarray, speech: tuple[int, int], n_frames: int) -> tuple[int, int]:
    """The frames ``[first, stop)`` kept around ``speech`` when the ``failed`` ones (none of
    them inside it) do not register: from the last failure before the speech to the first
    after it, both left out."""
    failed = np.asarray(failed, int)
    before, after = failed[failed < speech[0]], failed[failed >= speech[1]]
    return (
        int(before.max()) + 1 if before.size else 0,
        int(after.min()) if after.size else n_frames,
    )


def stabilize_clip(decoded: DecodedClip, stabilizer):
    """Register, conform and warp a clip, leaving out the frames around its speech that
    do not register (see the module docstring).

    Parameters
    ----------
    decoded : DecodedClip
        The clip as decoded and aligned.
    stabilizer : miketalk.stabilize.Stabilizer
        The corpus's.

    Returns
    -------
    (DecodedClip, miketalk.stabilize.Stabilized)
        The clip (``decoded`` itself when every frame registers, else its kept
        part) and its stabilized frames.

    Raises
    ------
    ClipError
        Naming the clip and the first frame in its speech that does not register.
    """
    name = f"clip {decoded.clip.id}"
    transforms = stabilizer.register(decoded.frames, clip=name, on_failure="nan")
    correlations = stabilizer.correlations.copy()
    if decoded.tracked is not None:  # face crops: ECC refines the tracker, it does not judge
        transforms, replaced = refine_crops(transforms, decoded.tracked, stabilizer)
        if replaced:
            log.info(
                "%s: %d of its %d tracked frames keep the tracker's transform (ECC in the crop "
                "does not refine it: another light or session)", name, replaced,
                int(decoded.tracked.sum()),
            )  # fmt: skip
    failed = np.flatnonzero(np.isnan(transforms[:, 0, 0]))
    if failed.size:
        n = len(decoded.frames)
        speech = speech_span(decoded.phones, decoded.fps, n)
        if (inside := failed[(failed >= speech[0]) & (failed < speech[1])]).size:
            first = int(inside[0])
            if decoded.tracked is not None and not decoded.tracked[first]:
                why = decoded.left_out[first]
                span = decoded.clip.span  # a part of a longer video: the video's frame
                which = f"its frame {first}" if span is None else f"frame {span[0] + first}"
                raise ClipError(f"{name}: {which} is left out ({why}), in its speech")
            raise ClipError(f"{stabilizer.failure(first, clip=name)}, in its speech")
        first, stop = kept_frames(failed, speech, n)
        log.warning(
            "%s: frames %s do not register to the reference; its frames %d to %d, around its "
            "speech, are kept", name, _ranges(failed), first, stop - 1,
        )  # fmt: skip
        decoded = decoded.cut(first, stop)
        transforms, correlations = transforms[first:stop], correlations[first:stop]
    return decoded, stabilizer.registered(decoded.frames, transforms, correlations, clip=name)


def _ranges(frames: np.ndarray) -> str:
    """``0-11, 70`` for frames 0 to 11 and 70."""
    parts, start = [], None
    for k, f in enumerate(frames):
        start = f if start is None else start
        if k + 1 == len(frames) or frames[k + 1] != f + 1:
            parts.append(f"{start}" if start == f else f"{start}-{f}")
            start = None
    return ", ".join(parts)


__all__ = ["kept_frames", "speech_span", "stabilize_clip"]
