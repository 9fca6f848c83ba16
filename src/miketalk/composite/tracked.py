"""A background from any video of the person: the face tracked, registered in its crop.

A model built in the face's canonical crop (:mod:`miketalk.track`; ``background.json``
records the crop) has its reference, face mask and mouth box in crop pixels. A video to
play under its mouth (its own frames at build time, ``say --background VIDEO``, ``dub``)
is read as crops (:func:`~miketalk.track.video_crops.crop_video`: tracked, cropped,
streamed), the crops are registered to the reference
(:func:`~miketalk.composite.registration.register_video`: ECC refines the tracker's
similarity, the conform field bends the reference's face onto the video's), and each
frame's transform is the composition of the two: reference pixel ``p`` shows in frame
``i`` at ``C_i^-1 (A_i (p + F(p)))``, ``A_i`` the crop registration and ``C_i`` the
frame-to-crop map. The compositor (:class:`~miketalk.composite.compositor.Compositor`)
carries the mouth through it into the frame at the video's own resolution, touching the
mouth's pixels only.

Neither the frames nor their crops are held: the crops are made again at each of the
registration's two readings (:class:`~miketalk.track.video_crops.StreamedCrops`; a short
video's, at most :data:`HOLD_CROPS_BYTES`, are read once and held), and
:class:`~miketalk.media.frame_source.VideoFrames` decodes the frames as the output is
written; memory does not grow with the video's length. Frames where the tracker found no one frontal
face (the face out of the picture, turned away, two faces, another shot) are named in a
warning and play as they are, without a new mouth (:attr:`Background.shown`): a mouth is
never put where no face was found.
"""

from __future__ import annotations

import logging
import os

import numpy as np

from miketalk import defaults
from miketalk.composite.background import MIN_SECONDS, Background
from miketalk.composite.kept_registration import untracked_warning
from miketalk.errors import MiketalkError
from miketalk.track.crop import FaceCropSettings
from miketalk.track.similarity import compose_affine, invert_affine

log = logging.getLogger(__name__)

__all__ = ["HOLD_CROPS_BYTES", "tracked_background"]

#: A video whose face crops take at most this many bytes has them held: read once, instead of
#: made again at each of the registration's two readings (a reading of 10 s of 720p costs
#: 0.85 s of CPU: its decoding and warping); a longer one's are streamed, so that memory does
#: not grow with the video's length (96 MB: 16 s at 30 fps of 256-pixel crops).
HOLD_CROPS_BYTES = 96 << 20


def tracked_background(
    path: str | os.PathLike[str],
    stabilizer,
    crop: FaceCropSettings,
    *,
    source: str | None = None,
    start: float | None = None,
    frames: int | None = None,
    progress: bool = False,
    smooth: float = defaults.BACKGROUND_SMOOTH,
    shortest: float = MIN_SECONDS,
    i420: bool = False,
    halves: bool = False,
) -> Background:
    """A video of the person registered through its face crops (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        The video.
    stabilizer : miketalk.stabilize.Stabilizer
        The model's, in crop pixels.
    crop : FaceCropSettings
        The model's crop.
    source : str, optional
        What errors call the video (its path by default).
    start : float, optional
        Seconds from the beginning (a part of a longer video).
    frames : int, optional
        At most this many frames.
    progress : bool
        Draw a progress bar of the registration.
    smooth : float
        Gaussian sigma in seconds of the crop registrations smoothed in time.
    shortest : float
        The fewest seconds the video may last.
    i420 : bool
        Its frames played in the encoder's colours where the video decodes to them
        (:func:`~miketalk.media.frame_source.played`: a mouth composited into them, each
        frame's box alone converted); False: RGB frames, as ffmpeg converts them.
    halves : bool
        The second half's face tracked in a child process, on another core
        (:func:`~miketalk.track.halves.track_in_halves`).

    Returns
    -------
    Background
        Its frames read when played (:class:`~miketalk.media.frame_source.VideoFrames`).

    Raises
    ------
    MiketalkError
        Unreadable, too short, no frontal face in most frames, or not the model's person.
    """
    from miketalk.composite.registration import register_video
    from miketalk.media.frame_source import VideoFrames, played
    from miketalk.track.video_crops import crop_video

    source = source or str(path)
    cropped = crop_video(path, crop=crop, start=start, frames=frames, source=source, hold=False,
                         halves=halves)  # fmt: skip
    fps, n = cropped.fps, len(cropped)
    if n / fps < shortest:
        raise MiketalkError(
            f"{source} lasts {n / fps:.2f} s ({n} frames at {fps:g} fps): a video to play "
            f"under the mouth must last at least {shortest:g} s"
        )
    failures = cropped.track.failures()
    left_out = tuple(str(f) for f in failures)
    untracked_warning(source, left_out, int((~cropped.tracked).sum()), n)
    if cropped.tracked.mean() < 0.5:
        raise MiketalkError(
            f"{source}: only {int(cropped.tracked.sum())} of its {n} frames show one frontal "
            f"face ({'; '.join(str(f) for f in failures[:3])}): give a video of the person "
            "facing the camera"
        )
    shot = _shots(cropped.track.segments, n)
    crops = cropped.crops
    if n * int(np.prod(crops.shape[1:])) <= HOLD_CROPS_BYTES:  # read once, not twice
        crops = _held(crops)
    found = register_video(
        crops, fps, stabilizer, source=source, progress=progress, smooth=smooth,
        usable=cropped.tracked, refine=True, shots=shot,
    )  # fmt: skip
    to_frame = np.stack([invert_affine(c) for c in cropped.to_crop])
    transforms = np.stack([compose_affine(f, t) for f, t in zip(to_frame, found.transforms,
                                                                strict=True)])  # fmt: skip
    if i420:
        video, planes = played(path, count=n, fps=fps, start=start or 0.0)
    else:
        video, planes = VideoFrames(path, count=n, fps=fps, start=start or 0.0), None
    return Background(
        video, transforms, found.field, fps, found.blinks, source, found.steady,
        shown=cropped.tracked.copy(), shot=shot, steady_shots=found.steady_shots,
        left_out=left_out, i420=planes,
    )  # fmt: skip


def _held(crops) -> np.ndarray:
    """The crops of one reading, in one array."""
    held = np.empty(crops.shape, np.uint8)
    for k, crop in enumerate(crops):
        held[k] = crop
    return held


def _shots(segments, n: int) -> np.ndarray:
    """Per frame the index of its tracked segment, -1 outside them."""
    shot = np.full(n, -1, np.int64)
    for k, (start, stop) in enumerate(segments):
        shot[start:stop] = k
    return shot
