"""A video (or part of one) read as canonical face crops: track, then crop, both streamed.

:func:`crop_video` reads the frames twice through ffmpeg (:func:`~miketalk.media.decode.
iter_video_frames`): once in grey to track the face (:func:`~miketalk.track.track.
track_frames`), once in RGB to warp each frame into the crop (:func:`~miketalk.track.crop.
face_crop`), only the part of the frames the crops see (:func:`crop_region`: the union of
the crops' windows; at 1080p a still face's is about a tenth of the frame), converted as
the crop's :attr:`~miketalk.track.crop.FaceCropSettings.conversion` says (by default
fast at HD, accurate below). ffmpeg's
conversion of every pixel to RGB was most of the build's cost that grew with the pixels
(12 ms of a 1080p frame's 15, the decoding 3 ms; read twice). With the ``accurate``
conversion the crops are the ones the whole RGB frames give, byte for byte. Memory holds
one frame at a time and the crops (``size``\\ :sup:`2` x 3 bytes a frame: 196 KB at
256 px, a minute at 30 fps is 350 MB), whatever the video's resolution; with
``hold=False`` not even the crops: they are made again at each reading
(:class:`StreamedCrops`, what a background registered through its crops reads twice), and
memory does not grow with the video's length.

A frame the tracker left out (no frontal face, several, landmarks that do not fit) is
cropped with its nearest tracked neighbour's transform, so that the crops stay one per
frame and in time, and flagged in :attr:`CroppedVideo.tracked`: what uses the crops
leaves such frames out (the corpus trims them around the speech or skips the clip;
a background takes its neighbours' registration) and never treats them as the face.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.track.crop import FaceCropSettings, chosen_conversion, warp_to_crop
from miketalk.track.resample import source_bounds
from miketalk.track.result import Track
from miketalk.track.similarity import compose_affine, invert_affine
from miketalk.track.track import TrackerSettings, track_frames

__all__ = [
    "CroppedVideo",
    "StreamedCrops",
    "crop_region",
    "crop_video",
    "crops_of",
    "nearest_tracked",
]

#: Pixels kept around the crops' windows in the decoded region: ffmpeg's RGB of an even
#: region's pixels 3 or more from its edges is the whole frame's (the 4:2:0 chroma's
#: interpolation; measured on GRID's MPEG-1 and x264's 4:2:0).
REGION_MARGIN = 4


@dataclass(frozen=True)
class CroppedVideo:
    """A video's frames as face crops, with where each crop came from.

    Attributes
    ----------
    crops : numpy.ndarray or StreamedCrops
        ``(N, size, size, 3)`` uint8 RGB: frame ``i``'s face crop (held, or made again at
        each reading).
    to_crop : numpy.ndarray
        ``(N, 2, 3)`` float64: frame ``i``'s pixels to its crop's pixels (a frame left
        out has its nearest tracked neighbour's).
    tracked : numpy.ndarray
        ``(N,)`` bool: the frames the tracker followed the face in.
    track : Track
        The tracker's record (why frames were left out, segments, cuts).
    fps : float
        The frames' rate.
    size : tuple of int
        The video's ``(width, height)``.
    """

    crops: np.ndarray | StreamedCrops
    to_crop: np.ndarray
    tracked: np.ndarray
    track: Track
    fps: float
    size: tuple[int, int]

    def __len__(self) -> int:
        return len(self.crops)

    def to_frame(self, index: int) -> np.ndarray:
        """``(2, 3)``: crop pixels of frame ``index`` to the frame's pixels."""
        return invert_affine(self.to_crop[index])


def nearest_tracked(transforms: np.ndarray) -> np.ndarray:
    """Each NaN transform replaced by the nearest finite one's (the earlier one on a tie).

    Parameters
    ----------
    transforms : numpy.ndarray
        ``(N, 2, 3)``, NaN where left out; at least one finite.

    Returns
    -------
    numpy.ndarray
        ``(N, 2, 3)`` all finite.
    """
    transforms = np.asarray(transforms, dtype=np.float64)
    ok = np.flatnonzero(np.isfinite(transforms).all(axis=(1, 2)))
    if not ok.size:
        raise MiketalkError("no frame has a transform")
    where = np.searchsorted(ok, np.arange(len(transforms)))
    before = ok[np.clip(where - 1, 0, len(ok) - 1)]
    after = ok[np.clip(where, 0, len(ok) - 1)]
    index = np.arange(len(transforms))
    nearest = np.where(np.abs(index - before) <= np.abs(after - index), before, after)
    return transforms[nearest]


def crop_region(
    to_crop: np.ndarray, settings: FaceCropSettings, size: tuple[int, int]
) -> tuple[int, int, int, int] | None:
    """The part of the frames that the crops of ``to_crop`` see, to decode only it.

    Parameters
    ----------
    to_crop : numpy.ndarray
        ``(N, 2, 3)`` frame-to-crop-pixel transforms, all finite.
    settings : FaceCropSettings
        The crop.
    size : tuple of int
        The frames' ``(width, height)``.

    Returns
    -------
    tuple of int or None
        ``(x, y, w, h)``: the union of every crop's source window
        (:func:`~miketalk.track.resample.source_bounds`) and :data:`REGION_MARGIN` pixels
        around it, all four even, within the frame; None if that is the whole frame (or
        would end on an odd-sized frame's edge).
    """
    width, height = size
    n = settings.size
    bounds = np.array([source_bounds((height, width), t, (n, n)) for t in to_crop])
    x0, y0 = (np.maximum(bounds[:, :2].min(axis=0) - REGION_MARGIN, 0) // 2 * 2).tolist()
    x1, y1 = bounds[:, 2:].max(axis=0) + REGION_MARGIN
    x1, y1 = min(int(x1 + x1 % 2), width), min(int(y1 + y1 % 2), height)
    if (x0, y0, x1, y1) == (0, 0, width, height) or (x1 - x0) % 2 or (y1 - y0) % 2:
        return None  # the whole frame, or an odd frame's edge (an odd-sized 4:2:0 region's
        # pixels are not the whole frame's)
    return int(x0), int(y0), x1 - int(x0), y1 - int(y0)


def crops_of(frames, to_crop: np.ndarray, settings: FaceCropSettings, count: int) -> np.ndarray:
    """The crops of ``count`` frames of a stream, each by its transform.

    Parameters
    ----------
    frames : iterable of numpy.ndarray
        The frames, in order (consumed up to ``count``).
    to_crop : numpy.ndarray
        ``(count, 2, 3)`` their frame-to-crop-pixel transforms, all finite.
    settings : FaceCropSettings
        The crop.
    count : int
        How many frames.

    Returns
    -------
    numpy.ndarray
        ``(count, size, size, 3)`` uint8.

    Raises
    ------
    MiketalkError
        If the stream ends early.
    """
    n = settings.size
    crops = np.empty((count, n, n, 3), np.uint8)
    for k, crop in enumerate(_warped(frames, to_crop, settings, count)):
        crops[k] = crop
    return crops


def _warped(
    frames: Iterable[np.ndarray], to_crop: np.ndarray, settings: FaceCropSettings, count: int
) -> Iterator[np.ndarray]:
    """Each of ``count`` frames warped into its crop, in order (:func:`crops_of`)."""
    k = 0
    for frame in frames:
        if k == count:
            break
        yield warp_to_crop(frame, to_crop[k], settings)
        k += 1
    if k < count:
        raise MiketalkError(
            f"the video gave {k} frames on its second reading, {count} on its first"
        )


class StreamedCrops:
    """A video's face crops, made again at each reading and never all held: ``len()`` and
    iteration (each a new reading of the video through ffmpeg, the bytes of
    :func:`crops_of`). Memory holds one frame and one crop, whatever the video's length.

    Parameters
    ----------
    path : str or os.PathLike
        The video.
    to_crop : numpy.ndarray
        ``(N, 2, 3)`` the decoded frames' pixels to the crops' (the region's, with
        ``region``).
    settings : FaceCropSettings
        The crop.
    start : float, optional
        Seconds from the beginning.
    region : tuple of int, optional
        The part of the frames decoded (:func:`crop_region`).
    conversion : str
        ffmpeg's RGB conversion (:func:`~miketalk.track.crop.chosen_conversion`).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        to_crop: np.ndarray,
        settings: FaceCropSettings,
        *,
        start: float | None = None,
        region: tuple[int, int, int, int] | None = None,
        conversion: str = "accurate",
    ) -> None:
        self.path, self.to_crop, self.settings = path, to_crop, settings
        self.start, self.region, self.conversion = start, region, conversion

    def __len__(self) -> int:
        return len(self.to_crop)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """``(N, size, size, 3)``."""
        return (len(self), self.settings.size, self.settings.size, 3)

    def __iter__(self) -> Iterator[np.ndarray]:
        from miketalk.media.decode import iter_video_frames

        frames = iter_video_frames(
            self.path, start=self.start, frames=len(self), region=self.region,
            conversion=self.conversion,
        )  # fmt: skip
        try:
            yield from _warped(frames, self.to_crop, self.settings, len(self))
        finally:
            frames.close()


def crop_video(
    path: str | os.PathLike[str],
    *,
    crop: FaceCropSettings | None = None,
    tracker: TrackerSettings | None = None,
    start: float | None = None,
    frames: int | None = None,
    source: str | None = None,
    hold: bool = True,
    halves: bool = False,
) -> CroppedVideo:
    """Track the face through a video (or ``frames`` of it from ``start``) and crop it.

    Parameters
    ----------
    path : str or os.PathLike
        Any video ffmpeg reads.
    crop : FaceCropSettings, optional
        The crop (the defaults otherwise).
    tracker : TrackerSettings, optional
        How the face is tracked.
    start : float, optional
        Seconds from the beginning.
    frames : int, optional
        At most this many frames.
    source : str, optional
        What to call the video in errors (its path by default).
    hold : bool
        Hold the crops (an array); False: make them again at each reading
        (:class:`StreamedCrops`), for what reads them a few times in order.
    halves : bool
        Track the second half of the frames in a child process, on another core
        (:func:`~miketalk.track.halves.track_in_halves`).

    Returns
    -------
    CroppedVideo

    Raises
    ------
    MiketalkError
        If the video cannot be read, or no frame shows one frontal face (the message
        says why the frames were left out).
    """
    from miketalk.media.decode import iter_video_frames, video_info

    crop = crop or FaceCropSettings()
    source = source or str(path)
    width, height, fps = video_info(path)
    if halves:
        from miketalk.track.halves import track_in_halves

        track = track_in_halves(path, fps=fps, settings=tracker, start=start, frames=frames)
    else:
        track = track_frames(iter_video_frames(path, start=start, frames=frames, grey=True),
                             fps=fps, settings=tracker)  # fmt: skip
    if not len(track):
        raise MiketalkError(f"{source}: no frame decoded")
    tracked = track.tracked
    if not tracked.any():
        reasons = "; ".join(str(f) for f in track.failures()[:3])
        raise MiketalkError(
            f"{source}: no frame shows one frontal face ({reasons}): give a video of one "
            "person facing the camera"
        )
    to_crop = np.stack([crop.transform(t) if ok else np.full((2, 3), np.nan)
                        for t, ok in zip(track.transforms, tracked, strict=True)])  # fmt: skip
    to_crop = nearest_tracked(to_crop)
    region = crop_region(to_crop, crop, (width, height))
    from_region = to_crop
    if region is not None:  # the region's pixels to the crop's: shifted by its corner
        shift = np.array([[1.0, 0.0, region[0]], [0.0, 1.0, region[1]]])
        from_region = np.stack([compose_affine(t, shift) for t in to_crop])
    pixels = region[2] * region[3] if region is not None else width * height
    conversion = chosen_conversion(crop, pixels)
    if hold:
        frames_rgb = iter_video_frames(
            path, start=start, frames=len(track), region=region, conversion=conversion
        )
        crops = crops_of(frames_rgb, from_region, crop, len(track))
    else:
        crops = StreamedCrops(
            path, from_region, crop, start=start, region=region, conversion=conversion
        )
    return CroppedVideo(crops, to_crop, tracked, track, float(fps), (int(width), int(height)))
