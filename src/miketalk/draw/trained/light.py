"""The trained face's patches brought to the light of the face they are drawn onto.

A face built from clips draws each output frame's mouth from a training frame, and its clips
were filmed on different days (a weekly address each): each clip's patches carry their day's
light. Drawn onto the model's silence image (whose light the compositor then matches to the
frames the mouth is pasted into: :mod:`miketalk.composite.colour`), a patch from another day
shows lips of another colour (pink lips from a brighter, pinker light among grey-brown ones).
Two ways, :data:`PATCH_LIGHTS` (:data:`miketalk.defaults.PATCH_LIGHT` is the default):

- ``"border"`` (:func:`border_shift`): each clip's patches shifted by one RGB offset, the
  face's mean colour on the patch's feathered border band minus the clip's mean border
  colour. The band holds the patch's corners too, where the backdrop and the collar show
  and move with the head: their colour, not the face's light, sets much of the offset.
- ``"session"`` (:class:`SessionLight`): each clip's colour transfer in CIELAB (after Reinhard
  et al. 2001: each channel's centre made the face's; its spread too when
  :data:`SPREAD_LIMIT` allows), estimated on the lower face about the mouth (an ellipse inside
  the patch: skin and lips, no backdrop) between the face's own pixels and the clip's frames
  whose mouth is shaped most like the face's (its description's nearest :data:`REST_FRAMES`;
  each frame's statistics, their median over those frames: a median image would be
  blurred): the same mouth shape, another day's light, so what differs is the light.

The paper's morph draws viseme images that the build cut from frames of those same clips:
each image is its frame's lower face laid onto the reference
(:func:`miketalk.corpus.viseme_choice.composite`), so it keeps its day's light too (a red
frame among brown ones). :func:`lit_visemes` brings them to the face's light the same way
(:meth:`miketalk.model.face.Model.lit_image`; the learned coarticulation draws them as
built), :data:`VISEME_LIGHTS` (:data:`miketalk.defaults.VISEME_LIGHT` is the default):
``"session"`` finds each image's own training frame among the trained face's
(:func:`source_frames`: the build pasted it unchanged), so its clip, and applies that clip's
:class:`SessionLight` transfer where the image is the frame's (:func:`pasted`); ``"built"``
leaves the images as the build made them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np

from miketalk.draw.trained.mouths import PATCH_EXTENT, MouthFrames, feather_mask, grey, patch_box
from miketalk.errors import MiketalkError
from miketalk.visemes import SILENCE

__all__ = [
    "PATCH_LIGHTS",
    "VISEME_LIGHTS",
    "PatchLight",
    "SessionLight",
    "border_shift",
    "check_viseme_light",
    "lit_visemes",
    "lower_face",
    "pasted",
    "patch_light",
    "source_frames",
]

#: The ways a training frame's patch is brought to the face's light (the module docstring).
PATCH_LIGHTS = ("border", "session")

#: The ways the morph's viseme images are brought to the face's light (the module docstring).
VISEME_LIGHTS = ("built", "session")

#: ``"session"``: a clip's frames nearest the face's mouth shape, whose statistics are compared.
REST_FRAMES = 15

#: ``"session"``: a channel's spread is scaled by at most this (or its inverse); 1: only the
#: centre moves. Measured (docs/anyone.md, "The trained face's patches"): 1.5 brought the lips as
#: near his on the weekly addresses (ΔE 2.77 against 2.70) but cost s1's held-out opening r
#: 0.014 (1: 0.004, within noise).
SPREAD_LIMIT = 1.0

#: ``"session"``: the lower face's ellipse about the mouth's centre, in mouth widths: half
#: its width, how far it reaches above and below the centre.
LOWER_FACE = (0.75, 0.5, 0.6)

#: :func:`source_frames`: the training frames nearest a viseme image in the description that
#: are compared with it pixel by pixel.
NEAREST = 8

#: :func:`source_frames`: the largest mean absolute difference (levels, over the mouth region's
#: colours) at which a training frame is the one a viseme image was cut from. Measured on five
#: models (s1's 8 clips, the four folds of the weekly addresses; 80 images): 0.04 to 0.79 for
#: its own frame, 1.32 or more for any other.
MATCH_LEVELS = 1.0


def _lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB of float RGB in [0, 255] (float32; L* 0-100)."""
    return cv2.cvtColor(np.clip(rgb, 0, 255).astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab)


def _rgb(lab: np.ndarray) -> np.ndarray:
    """Float RGB in [0, 255] of CIELAB (float32)."""
    return cv2.cvtColor(lab.astype(np.float32), cv2.COLOR_Lab2RGB) * np.float32(255.0)


@dataclass(frozen=True)
class PatchLight:
    """``"border"``: each clip's way to the face's light, ``patch + shift`` in RGB.

    Attributes
    ----------
    shift : numpy.ndarray
        (clips, 3) float32.
    """

    shift: np.ndarray

    def apply(self, patch: np.ndarray, clip: int) -> np.ndarray:
        """``patch`` (uint8 or float RGB) of clip ``clip`` in the face's light (float32)."""
        return np.asarray(patch, np.float32) + self.shift[clip]


def border_shift(frames: MouthFrames, under: np.ndarray) -> PatchLight:
    """``"border"``: the face's mean border colour minus each clip's (the module docstring).

    Parameters
    ----------
    frames : MouthFrames
        The trained face's frames (their ``border`` colours).
    under : numpy.ndarray
        (ph, pw, 3) the face's own pixels under the patch.
    """
    h, w = under.shape[:2]
    mask = feather_mask(h, w)
    band = (mask > 0.02) & (mask < 0.98)
    face_border = np.asarray(under, np.float32)[band].mean(axis=0)
    # each clip's mean border colour: its session's light (a frame's own border moves with
    # the jaw, and matching it would cancel the mouth's own shading)
    count = np.bincount(frames.clip, minlength=len(frames.clip_ids)).astype(np.float64)
    sums = np.stack(
        [np.bincount(frames.clip, frames.border[:, c], len(frames.clip_ids)) for c in range(3)],
        axis=1,
    )
    return PatchLight((face_border - sums / np.maximum(count, 1.0)[:, None]).astype(np.float32))


def _centre_spread(lab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each channel's median and half its 16th-84th percentile range (a standard deviation
    that a few pixels of collar or shadow do not move), of (n, 3) pixels."""
    low, mid, high = np.percentile(lab, (16, 50, 84), axis=0)
    return mid.astype(np.float32), ((high - low) / 2).astype(np.float32)


def lower_face(frames: MouthFrames) -> np.ndarray:
    """(ph, pw) bool: the ellipse of :data:`LOWER_FACE` about the mouth region's centre,
    inside the patch's feathered mask (the whole of that inside where the ellipse misses it: a
    patch not cut about its mouth region)."""
    px, py, pw, ph = frames.patch
    rx, ry, rw, rh = frames.region
    width = pw / (2.0 * PATCH_EXTENT[0])  # the mouth's width the patch was cut by
    cx, cy = rx - px + rw / 2.0, ry - py + rh / 2.0
    half, above, below = (v * width for v in LOWER_FACE)
    yy, xx = np.mgrid[0:ph, 0:pw].astype(np.float32)
    reach = np.where(yy < cy, above, below)
    inside = ((xx - cx) / half) ** 2 + ((yy - cy) / reach) ** 2 <= 1.0
    masked = feather_mask(ph, pw) > 0.5
    return inside & masked if (inside & masked).any() else masked


class SessionLight:
    """``"session"``: each clip's CIELAB transfer to the face's light (the module docstring),
    found the first time one of the clip's patches is drawn (a sentence draws from a few of
    a long build's clips; each costs the reading of :data:`REST_FRAMES` patches).

    Parameters
    ----------
    frames : MouthFrames
        The trained face's frames.
    face : numpy.ndarray
        (H, W, 3) uint8 RGB, the image the patches are drawn onto.
    """

    def __init__(self, frames: MouthFrames, face: np.ndarray) -> None:
        px, py, pw, ph = frames.patch
        rx, ry, rw, rh = frames.region
        self.frames = frames
        self.where = lower_face(frames)
        self.target = _centre_spread(_lab(face[py : py + ph, px : px + pw])[self.where])
        self.shape = frames.project(grey(face[None, ry : ry + rh, rx : rx + rw]))[0]
        self._clips: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def transfer(self, clip: int) -> tuple[np.ndarray, np.ndarray]:
        """Clip ``clip``'s ``(scale, shift)``, (3,) float32 each: ``lab * scale + shift``."""
        if clip in self._clips:
            return self._clips[clip]
        idx = np.flatnonzero(self.frames.clip == clip)
        if not len(idx):
            raise MiketalkError(f"the trained face has no frame of clip {clip}")
        distance = np.linalg.norm(self.frames.coords[idx] - self.shape, axis=1)
        idx = idx[np.argsort(distance, kind="stable")[:REST_FRAMES]]
        # each frame's own statistics, their median over the frames (a median image
        # would be blurred: its spread under the face's sharp one)
        stats = [_centre_spread(_lab(self.frames.patches[i])[self.where]) for i in np.sort(idx)]
        s_mean = np.median([m for m, _ in stats], axis=0)
        s_sd = np.median([d for _, d in stats], axis=0)
        t_mean, t_sd = self.target
        ratio = np.divide(t_sd, s_sd, out=np.ones(3, np.float32), where=s_sd > 1e-3)
        scale = np.clip(ratio, 1.0 / SPREAD_LIMIT, SPREAD_LIMIT).astype(np.float32)
        self._clips[clip] = scale, (t_mean - s_mean * scale).astype(np.float32)
        return self._clips[clip]

    def apply(self, patch: np.ndarray, clip: int) -> np.ndarray:
        """``patch`` (uint8 or float RGB) of clip ``clip`` in the face's light (float32)."""
        scale, shift = self.transfer(clip)
        return _rgb(_lab(np.asarray(patch, np.float32)) * scale + shift)


def patch_light(frames: MouthFrames, face: np.ndarray, how: str) -> PatchLight | SessionLight:
    """The light of ``how`` (:data:`PATCH_LIGHTS`): :class:`SessionLight` or
    :func:`border_shift`'s, from ``frames`` to ``face`` ((H, W, 3) uint8 RGB)."""
    if how == "session":
        return SessionLight(frames, face)
    if how == "border":
        x, y, w, h = frames.patch
        return border_shift(frames, face[y : y + h, x : x + w])
    raise MiketalkError(f"the patches' light must be {' or '.join(PATCH_LIGHTS)}, not {how!r}")


def source_frames(images: Mapping[str, np.ndarray], frames: MouthFrames) -> dict[str, int | None]:
    """Each viseme image's own training frame (an index of ``frames``; None: none matches).

    The build laid each frame's lower face unchanged onto the reference: inside the mouth
    region the image is the frame's, to the rounding. Of the :data:`NEAREST` frames nearest
    the image in the description, the one whose mouth region differs least from it, when that
    mean absolute difference is at most :data:`MATCH_LEVELS`.
    """
    px, py = frames.patch[:2]
    rx, ry, rw, rh = frames.region
    names = tuple(images)
    regions = np.stack([images[v][ry : ry + rh, rx : rx + rw] for v in names]).astype(np.float32)
    coords = frames.project(grey(regions))
    out: dict[str, int | None] = {}
    for name, c, region in zip(names, coords, regions, strict=True):
        near = np.argsort(np.linalg.norm(frames.coords - c, axis=1), kind="stable")[:NEAREST]
        cut = (slice(ry - py, ry - py + rh), slice(rx - px, rx - px + rw))
        diff = [float(np.abs(frames.patches[s][cut].astype(np.float32) - region).mean())
                for s in near]  # fmt: skip
        best = int(np.argmin(diff))
        out[name] = int(near[best]) if diff[best] <= MATCH_LEVELS else None
    return out


def pasted(frames: MouthFrames, size: tuple[int, int]) -> np.ndarray:
    """(H, W) float32: how much of a viseme image is its own frame's, the build's paste
    (:func:`miketalk.corpus.viseme_choice.paste_weight` over the flow region,
    :func:`miketalk.mouth.flow_region`), about the mouth box that ``frames``' mouth region
    was cut about (its centre and width; ``size`` (H, W))."""
    from miketalk.corpus.viseme_choice import PASTE_FEATHER, paste_weight
    from miketalk.mouth.region import FLOW_EXTENT, REGION_EXTENT

    rx, ry, rw, _ = frames.region
    side, above, _ = REGION_EXTENT
    width = rw / (2.0 * side)
    centre = (rx + rw / 2.0, ry + above * width)
    box = patch_box((centre[0] - width / 2.0, centre[1], width, 0), size, FLOW_EXTENT)
    return paste_weight(size, box, feather=PASTE_FEATHER * rw)


def check_viseme_light(how: str) -> str:
    """``how`` when it is one of :data:`VISEME_LIGHTS`, else a one-line :class:`MiketalkError`."""
    if how not in VISEME_LIGHTS:
        raise MiketalkError(
            f"the viseme images' light must be {' or '.join(VISEME_LIGHTS)}, not {how!r}"
        )
    return how


def lit_visemes(
    images: Mapping[str, np.ndarray], frames: MouthFrames, how: str = "session"
) -> dict[str, np.ndarray]:
    """The viseme images (``viseme -> (H, W, 3) uint8``, with the silence image, the face)
    brought to the face's light by ``how`` (:data:`VISEME_LIGHTS`, the module docstring).

    ``"session"``: each image whose own frame :func:`source_frames` finds gets that frame's
    clip's :class:`SessionLight` transfer (the trained face's, onto the silence image)
    weighed by :func:`pasted`; the silence image, and an image whose frame is not found, stay
    as built.
    """
    check_viseme_light(how)
    if how == "built" or SILENCE not in images:
        return dict(images)
    face = images[SILENCE]
    light = SessionLight(frames, face)
    weight = pasted(frames, face.shape[:2])[..., None]
    out = dict(images)
    for name, s in source_frames(images, frames).items():
        if name == SILENCE or s is None:
            continue
        image = np.asarray(images[name], np.float32)
        lit = light.apply(image, int(frames.clip[s]))
        out[name] = np.clip(np.rint(image + weight * (lit - image)), 0, 255).astype(np.uint8)
    return out
