"""The canonical face crop: every tracked frame's face at one size and place, and back.

:class:`FaceCropSettings` fixes the crop: ``size`` pixels square, the eyes
``eye_distance`` pixels apart on a horizontal line ``eyes_y`` of the way down, midway
across. The defaults (256 px, 72 px, 0.36) put the eye line 92 px from the top
(1.28 eye distances: the forehead up to the hairline) and leave 164 px below it (2.28
eye distances: mouth, chin and the jaw's opening below it) and 1.78 eye distances
either side of the face's centre line (the cheeks and the ears' roots).

:meth:`FaceCropSettings.transform` is a frame's map to crop pixels (the track's
frame-to-canonical transform followed by the crop's scale and offset);
:func:`face_crop` warps a frame by it (:func:`~miketalk.track.resample.warp_affine`:
bicubic when the crop enlarges the face, bilinear when it shrinks it by up to 2, an area
average then bicubic beyond); :func:`iter_face_crops` streams the crops of a track's frames.
:func:`paste_back` puts a crop-sized image back into the full-resolution frame
through the inverse map, blended by a feathered mask (:func:`face_mask`: an ellipse
over the face) over the frame's pixels that the crop covers only.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.decode import COLOUR_CONVERSIONS
from miketalk.track.resample import warp_affine
from miketalk.track.similarity import compose_affine, invert_affine

__all__ = [
    "CANONICAL_MOUTH",
    "FaceCropSettings",
    "crop_doc",
    "crop_from_doc",
    "face_crop",
    "face_mask",
    "iter_face_crops",
    "jaw_mask",
    "mouth_box",
    "paste_back",
    "warp_to_crop",
]

_INTERPOLATIONS = {"auto": None, "linear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC}


@dataclass(frozen=True)
class FaceCropSettings:
    """The canonical face crop's geometry.

    Attributes
    ----------
    size : int
        The crop's width and height in pixels.
    eye_distance : float
        The canonical face's eye distance in crop pixels (the canonical unit). A
        person's own eyes are a few percent nearer or further (the frame's similarity
        is fitted to all five landmarks, the nose's too: s1's are 0.95 of it).
    eyes_y : float
        The eye line's height as a fraction of ``size`` from the top.
    interpolation : str
        ``"auto"`` (by the scale: bicubic when the crop enlarges the face, bilinear when
        it shrinks it by up to 2, an area average then bicubic beyond; see
        :mod:`~miketalk.track.resample` for the measurements), ``"linear"`` or
        ``"cubic"`` (after an area average when the crop shrinks the face by more than 2).
    conversion : str
        ffmpeg's YUV-to-RGB conversion of the pixels the crops are drawn from:
        ``"accurate"`` (the whole frames' conversion; a corpus or model that records none
        was read so), ``"fast"`` (no accurate rounding: about 4 times cheaper, RGB 1.1 to 1.3
        levels lower on average, up to 4 in a 1080p face's crop, up to 29 in a 360x288
        one's, where the crop enlarges the face) or ``"auto"``: fast when the frames'
        part the crops see holds at least :data:`AUTO_FAST_PIXELS` times the crop's
        pixels (each crop pixel an average of several, the rounding's noise averaged
        away: HD), accurate otherwise (where it costs little). Measured on hard s1
        (720p) and plain s1 (360x288), in ``docs/tracking.md``.
    """

    size: int = 256
    eye_distance: float = 72.0
    eyes_y: float = 0.36
    interpolation: str = "auto"
    conversion: str = "auto"

    def __post_init__(self) -> None:
        if isinstance(self.size, bool) or not isinstance(self.size, int) or self.size < 16:
            raise MiketalkError(f"the crop's size must be a whole number >= 16, got {self.size!r}")
        if not (math.isfinite(self.eye_distance) and 0 < self.eye_distance <= self.size):
            raise MiketalkError(f"eye_distance must be in (0, size], got {self.eye_distance!r}")
        if not 0 < self.eyes_y < 1:
            raise MiketalkError(f"eyes_y must be in (0, 1), got {self.eyes_y!r}")
        if self.interpolation not in _INTERPOLATIONS:
            known = sorted(_INTERPOLATIONS)
            raise MiketalkError(f"interpolation must be one of {known}, got {self.interpolation!r}")
        if self.conversion not in (*COLOUR_CONVERSIONS, AUTO):
            known = sorted((*COLOUR_CONVERSIONS, AUTO))
            raise MiketalkError(f"conversion must be one of {known}, got {self.conversion!r}")

    @property
    def canonical_to_crop(self) -> np.ndarray:
        """``(2, 3)``: canonical coordinates (eye distances) to crop pixels."""
        e = float(self.eye_distance)
        return np.array([[e, 0.0, (self.size - 1) / 2], [0.0, e, self.eyes_y * self.size - 0.5]])

    def transform(self, track_transform: np.ndarray) -> np.ndarray:
        """A frame's map to crop pixels, from its frame-to-canonical transform.

        Parameters
        ----------
        track_transform : numpy.ndarray
            ``(2, 3)`` frame-to-canonical (a :class:`~miketalk.track.result.Track`'s).

        Returns
        -------
        numpy.ndarray
            ``(2, 3)`` frame pixels to crop pixels.
        """
        t = np.asarray(track_transform, dtype=np.float64)
        if t.shape != (2, 3) or not np.isfinite(t).all():
            raise MiketalkError(f"a frame's transform must be a finite (2, 3) array, got {t}")
        return compose_affine(self.canonical_to_crop, t)


#: :attr:`FaceCropSettings.conversion`'s choice by the pixels read (see there).
AUTO = "auto"
#: ``auto`` converts fast when the frames' part read holds this many times the crop's pixels.
AUTO_FAST_PIXELS = 2.0


def chosen_conversion(settings: FaceCropSettings, region_pixels: int) -> str:
    """The conversion that reads ``region_pixels`` of each frame into ``settings``' crops:
    its own, or ``auto``'s choice (fast from :data:`AUTO_FAST_PIXELS` times the crop's
    pixels)."""
    if settings.conversion != AUTO:
        return settings.conversion
    return "fast" if region_pixels >= AUTO_FAST_PIXELS * settings.size**2 else "accurate"


#: The closed lips in canonical coordinates (eye distances): ``(u0, v0, u1, v1)``. dlib's
#: 68 points (in the evaluation only) on the crops of two weekly addresses and a GRID s1
#: clip put the lips, over speech, at u -0.46 to 0.45 and v 0.97 to 1.44 (s1: 1.12 to
#: 1.42); GRID's own mouth box, found from where the face moves, holds the closed lips
#: with a few pixels' margin, as this one does.
CANONICAL_MOUTH = (-0.5, 1.0, 0.5, 1.4)


def mouth_box(settings: FaceCropSettings | None = None) -> tuple[int, int, int, int]:
    """The mouth box ``(x, y, w, h)`` in the crop's pixels (:data:`CANONICAL_MOUTH`)."""
    settings = settings or FaceCropSettings()
    to_crop = settings.canonical_to_crop
    u0, v0, u1, v1 = CANONICAL_MOUTH
    x0 = round(to_crop[0, 0] * u0 + to_crop[0, 2])
    y0 = round(to_crop[1, 1] * v0 + to_crop[1, 2])
    x1 = round(to_crop[0, 0] * u1 + to_crop[0, 2])
    y1 = round(to_crop[1, 1] * v1 + to_crop[1, 2])
    return x0, y0, x1 - x0, y1 - y0


def crop_doc(settings: FaceCropSettings) -> dict:
    """The crop's geometry as JSON-ready values (what a corpus or a model records)."""
    return {
        "size": settings.size,
        "eye_distance": settings.eye_distance,
        "eyes_y": settings.eyes_y,
        "interpolation": settings.interpolation,
        "conversion": settings.conversion,
    }


def crop_from_doc(doc: dict | None) -> FaceCropSettings | None:
    """:func:`crop_doc`'s values back as settings (None for None: frames as recorded)."""
    if doc is None:
        return None
    return FaceCropSettings(
        size=int(doc["size"]),
        eye_distance=float(doc["eye_distance"]),
        eyes_y=float(doc["eyes_y"]),
        interpolation=str(doc.get("interpolation", "auto")),
        conversion=str(doc.get("conversion", "accurate")),
    )


def face_crop(
    frame: np.ndarray, track_transform: np.ndarray, settings: FaceCropSettings | None = None
) -> np.ndarray:
    """The canonical face crop of one frame.

    Parameters
    ----------
    frame : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB at the video's own resolution.
    track_transform : numpy.ndarray
        ``(2, 3)`` the frame's frame-to-canonical transform.
    settings : FaceCropSettings, optional
        The crop's geometry (the defaults otherwise).

    Returns
    -------
    numpy.ndarray
        ``(size, size, 3)`` uint8 RGB (beyond the frame's edges, its edge pixels repeated).
    """
    settings = settings or FaceCropSettings()
    return warp_to_crop(frame, settings.transform(track_transform), settings)


def warp_to_crop(frame: np.ndarray, to_crop: np.ndarray, settings: FaceCropSettings) -> np.ndarray:
    """A frame warped into the crop by its frame-to-crop-pixel map (:meth:`FaceCropSettings.
    transform`): :func:`face_crop` when the map is already made.

    Returns
    -------
    numpy.ndarray
        ``(size, size, 3)`` uint8 RGB.
    """
    size = (settings.size, settings.size)
    return warp_affine(frame, to_crop, size, interpolation=_INTERPOLATIONS[settings.interpolation])


def iter_face_crops(
    frames: Iterable[np.ndarray],
    transforms: np.ndarray,
    settings: FaceCropSettings | None = None,
) -> Iterator[tuple[int, np.ndarray]]:
    """Stream the face crops of the tracked frames of a stream of frames.

    Parameters
    ----------
    frames : iterable of numpy.ndarray
        The video's frames, in order (e.g. :func:`~miketalk.media.decode.iter_video_frames`).
    transforms : numpy.ndarray
        ``(N, 2, 3)`` their frame-to-canonical transforms, NaN for a frame left out
        (a :class:`~miketalk.track.result.Track`'s ``transforms``).
    settings : FaceCropSettings, optional
        The crop's geometry.

    Yields
    ------
    index : int
        The frame's index.
    crop : numpy.ndarray
        Its crop; frames left out are skipped.

    Raises
    ------
    MiketalkError
        If there are more frames than transforms.
    """
    settings = settings or FaceCropSettings()
    transforms = np.asarray(transforms, dtype=np.float64)
    for index, frame in enumerate(frames):
        if index >= len(transforms):
            raise MiketalkError(f"frame {index} has no transform ({len(transforms)} given)")
        if np.isfinite(transforms[index]).all():
            yield index, face_crop(frame, transforms[index], settings)


def _ellipse(
    settings: FaceCropSettings, centre_v: float, across: float, down: float, feather: float
) -> np.ndarray:
    """A feathered ellipse on the face's centre line, in eye distances (0.5 on its edge)."""
    n, e = settings.size, settings.eye_distance
    to_crop = settings.canonical_to_crop
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float64)
    u = (xx - to_crop[0, 2]) / e
    v = (yy - to_crop[1, 2]) / e
    r = np.sqrt((u / across) ** 2 + ((v - centre_v) / down) ** 2)
    # signed distance from the ellipse, roughly, in eye distances (the smaller semi-axis)
    distance = (r - 1.0) * min(across, down)
    mask = 0.5 * (1.0 - np.tanh(distance / max(feather, 1e-6) * 1.2))
    return mask.astype(np.float32)


def face_mask(settings: FaceCropSettings | None = None, *, feather: float = 0.15) -> np.ndarray:
    """A feathered ellipse over the face in the crop: where a crop replaces the frame.

    The ellipse is centred on the face's centre line 0.5 eye distances below the eye line
    and has semi-axes of 1.2 (across) and 1.65 (down) eye distances: from the forehead
    1.15 above the eyes to below the chin, 2.15 below them, cheek to cheek. Its edge is
    blurred by a Gaussian of ``feather`` eye distances (the mask is 0.5 on the ellipse).

    Parameters
    ----------
    settings : FaceCropSettings, optional
        The crop's geometry.
    feather : float
        The edge's softness in eye distances.

    Returns
    -------
    numpy.ndarray
        ``(size, size)`` float32 in [0, 1].
    """
    return _ellipse(settings or FaceCropSettings(), 0.5, 1.2, 1.65, feather)


def jaw_mask(settings: FaceCropSettings | None = None, *, feather: float = 0.1) -> np.ndarray:
    """A feathered ellipse inside the lower face's outline: where a new mouth may show.

    Centred 1.05 eye distances below the eye line, 0.95 across and 0.85 down: to 1.9
    below the eyes (dlib's 68 points put the chin at 1.95 to 2.07 in the crops of s1 and
    the weekly addresses) and inside the cheeks, so that a mouth drawn from another
    session never carries its collar or backdrop over a jaw turned elsewhere.

    Returns
    -------
    numpy.ndarray
        ``(size, size)`` float32 in [0, 1].
    """
    return _ellipse(settings or FaceCropSettings(), 1.05, 0.95, 0.85, feather)


def paste_back(
    frame: np.ndarray,
    crop_image: np.ndarray,
    transform: np.ndarray,
    mask: np.ndarray | None = None,
    *,
    interpolation: int | None = None,
) -> np.ndarray:
    """Put a crop-sized image back into its full-resolution frame, blended by a mask.

    Parameters
    ----------
    frame : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB: the frame the crop was made from (not changed).
    crop_image : numpy.ndarray
        ``(h, w, 3)`` uint8 RGB in the crop's pixels (the crop, or an image made from it).
    transform : numpy.ndarray
        ``(2, 3)`` frame pixels to crop pixels (:meth:`FaceCropSettings.transform`).
    mask : numpy.ndarray, optional
        ``(h, w)`` float in [0, 1]: how much of the crop shows (:func:`face_mask`). By
        default the whole crop, feathered over its outer 4 % on each side.
    interpolation : int, optional
        OpenCV interpolation of the warp into the frame; by default by its scale
        (:func:`~miketalk.track.resample.interpolation_for`).

    Returns
    -------
    numpy.ndarray
        A new ``(H, W, 3)`` uint8 frame: ``frame`` where the mask is 0, the crop
        where it is 1. Only the frame's pixels under the crop are computed.

    Raises
    ------
    MiketalkError
        If the shapes do not fit.
    """
    frame = np.asarray(frame)
    crop_image = np.asarray(crop_image)
    if frame.ndim != 3 or crop_image.ndim != 3 or frame.shape[2] != crop_image.shape[2]:
        raise MiketalkError(
            f"paste_back needs (H, W, 3) images, got {frame.shape} and {crop_image.shape}"
        )
    h, w = crop_image.shape[:2]
    if mask is None:
        mask = _border_mask(h, w)
    mask = np.asarray(mask, dtype=np.float32)
    if mask.shape != (h, w):
        raise MiketalkError(f"the mask is {mask.shape}, the crop {(h, w)}")
    to_frame = invert_affine(transform)
    corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5], [w - 0.5, h - 0.5]])
    seen = corners @ to_frame[:, :2].T + to_frame[:, 2]
    height, width = frame.shape[:2]
    x0 = max(math.floor(seen[:, 0].min()), 0)
    y0 = max(math.floor(seen[:, 1].min()), 0)
    x1 = min(math.ceil(seen[:, 0].max()) + 1, width)
    y1 = min(math.ceil(seen[:, 1].max()) + 1, height)
    out = frame.copy()
    if x1 <= x0 or y1 <= y0:
        return out
    to_roi = compose_affine(np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0]]), to_frame)
    size = (x1 - x0, y1 - y0)
    pasted = warp_affine(crop_image, to_roi, size, interpolation=interpolation)
    alpha = warp_affine(
        mask, to_roi, size, interpolation=cv2.INTER_LINEAR, border_mode=cv2.BORDER_CONSTANT
    )
    alpha = np.clip(alpha, 0.0, 1.0)[..., None]
    roi = out[y0:y1, x0:x1].astype(np.float32)
    blended = roi + alpha * (pasted.astype(np.float32) - roi)
    out[y0:y1, x0:x1] = np.clip(np.rint(blended), 0, 255).astype(np.uint8)
    return out


def _border_mask(h: int, w: int) -> np.ndarray:
    """1 inside, falling smoothly to 0 over the outer 4 % of each side."""

    def ramp(n: int) -> np.ndarray:
        edge = max(0.04 * n, 1.0)
        i = np.arange(n, dtype=np.float64)
        d = np.minimum(i + 0.5, n - 0.5 - i) / edge
        return np.clip(d, 0.0, 1.0)

    return np.outer(ramp(h), ramp(w)).astype(np.float32)
