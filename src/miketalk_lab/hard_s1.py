"""Hard s1: GRID's talker s1 in a room, moving, in HD, with the motion known exactly.

GRID's s1 is the easy case of face tracking: 360x288, a plain blue backdrop, a still
head. This makes it hard while keeping the truth: each clip's person is keyed off the
backdrop (:func:`chroma_alpha`), put in front of a textured room (:func:`room`: shelves
of books, procedural, from a seed), scaled by about 2 into a 1280x720 frame and moved
by a known smooth similarity (:func:`hard_motion`: translation up to 40 px, roll up to
8 degrees, scale up to 10 %, sinusoids of different periods and of phases drawn from
the seed and the clip's name). The truth of frame ``k`` is that similarity, a ``(2, 3)``
map from the original clip's pixel coordinates to the hard frame's: a point tracked in
the plain clip, mapped by it, is where the same point is in the hard frame.

Everything is deterministic: the same clip, size and seed give the same arrays, and
(:func:`make_hard_clip`, through :func:`miketalk.media.video.write_mp4`) the same mp4
bytes, with the clip's own sound.
"""

from __future__ import annotations

import math
import os
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio, read_video
from miketalk.media.video import write_mp4

__all__ = [
    "FACE_CENTRE",
    "HardClip",
    "HardMotion",
    "chroma_alpha",
    "hard_frames",
    "hard_motion",
    "make_hard_clip",
    "room",
]

#: The centre of s1's face in his 360x288 clips (between the eyes and the nose): the
#: pivot of the motion's roll and scale, and what is placed in the hard frame.
FACE_CENTRE = (155.0, 170.0)
#: Where the face's centre is put in the hard frame, as fractions of its width and height.
ANCHOR = (0.5, 0.42)
#: The clip's scale in a 720-pixel-high frame (a 1080-pixel-high one: 3).
BASE_SCALE_720 = 2.0
#: The key: ``min(G, B) - R`` at or below ``KEY_LOW`` is the person, at or above
#: ``KEY_HIGH`` the backdrop (GRID's is cyan-blue: 85 to 175; skin, hair and s1's
#: shirts are below 45), linear in between.
KEY_LOW, KEY_HIGH = 45.0, 75.0
_AUDIO_RATE = 16000
_TOP_ROWS = 2
_SIDE_FADE = 8.0


@dataclass(frozen=True)
class HardMotion:
    """The known motion's amplitudes (at 720p) and periods.

    Attributes
    ----------
    translation : float
        Largest shift in x, pixels of a 720-pixel-high frame (y: three quarters of it).
    rotation : float
        Largest roll, degrees.
    scale : float
        Largest relative change of scale.
    periods : tuple of float
        Periods in seconds of the x shift, y shift, roll and scale.
    """

    translation: float = 40.0
    rotation: float = 8.0
    scale: float = 0.10
    periods: tuple[float, float, float, float] = (2.9, 3.7, 3.3, 4.1)


@dataclass(frozen=True)
class HardClip:
    """A hard clip written to disk and its truth.

    Attributes
    ----------
    path : pathlib.Path
        The mp4.
    truth : numpy.ndarray
        ``(N, 2, 3)`` float64: frame ``k``'s map from the original clip's pixel
        coordinates to the hard frame's.
    fps : float
        The frame rate (the clip's).
    size : tuple of int
        The hard frames' ``(width, height)``.
    """

    path: Path
    truth: np.ndarray
    fps: float
    size: tuple[int, int]


def _clip_rng(seed: int, name: str) -> np.random.Generator:
    return np.random.default_rng([int(seed), zlib.crc32(name.encode("utf-8"))])


def hard_motion(
    n_frames: int,
    fps: float,
    *,
    size: tuple[int, int] = (1280, 720),
    seed: int = 0,
    name: str = "",
    motion: HardMotion | None = None,
    face_centre: tuple[float, float] = FACE_CENTRE,
) -> np.ndarray:
    """The known motion of a clip: per frame, the map from clip pixels to hard-frame pixels.

    ``x -> A + d(t) + s(t) R(a(t)) (x - c)`` with ``c`` the face's centre in the clip,
    ``A`` its place in the hard frame (:data:`ANCHOR`), ``s(t)`` the base scale
    (:data:`BASE_SCALE_720` times the frame's height over 720) times ``1 + scale sin(.)``,
    ``a(t)`` the roll ``rotation sin(.)`` and ``d(t)`` the shift, each a sinusoid of its
    period with a phase drawn from ``seed`` and ``name``.

    Parameters
    ----------
    n_frames : int
        How many frames.
    fps : float
        Their rate (``t = k / fps``).
    size : tuple of int
        The hard frame's ``(width, height)``.
    seed : int
        The phases' seed (with ``name``).
    name : str
        The clip's name.
    motion : HardMotion, optional
        Amplitudes and periods.
    face_centre : tuple of float
        The pivot ``c``.

    Returns
    -------
    numpy.ndarray
        ``(n_frames, 2, 3)`` float64.
    """
    motion = motion or HardMotion()
    phases = _clip_rng(seed, name).uniform(0.0, 2.0 * math.pi, 4)
    width, height = size
    unit = height / 720.0
    t = np.arange(n_frames, dtype=np.float64) / float(fps)
    px, py, pa, ps = motion.periods
    dx = motion.translation * unit * np.sin(2 * math.pi * t / px + phases[0])
    dy = 0.75 * motion.translation * unit * np.sin(2 * math.pi * t / py + phases[1])
    angle = np.radians(motion.rotation) * np.sin(2 * math.pi * t / pa + phases[2])
    scale = BASE_SCALE_720 * unit * (1.0 + motion.scale * np.sin(2 * math.pi * t / ps + phases[3]))
    cx, cy = face_centre
    ax, ay = ANCHOR[0] * width - 0.5 + dx, ANCHOR[1] * height - 0.5 + dy
    c, s = scale * np.cos(angle), scale * np.sin(angle)
    out = np.empty((n_frames, 2, 3))
    out[:, 0, 0], out[:, 0, 1], out[:, 0, 2] = c, -s, ax - (c * cx - s * cy)
    out[:, 1, 0], out[:, 1, 1], out[:, 1, 2] = s, c, ay - (s * cx + c * cy)
    return out


def room(size: tuple[int, int] = (1280, 720), *, seed: int = 0) -> np.ndarray:
    """A procedural room behind the person: a wall, shelves of books, noise.

    Parameters
    ----------
    size : tuple of int
        ``(width, height)``; the layout scales with the height.
    seed : int
        Everything random is drawn from it.

    Returns
    -------
    numpy.ndarray
        ``(height, width, 3)`` uint8 RGB.
    """
    width, height = size
    rng = np.random.default_rng(int(seed))
    u = height / 720.0
    # a wall: beige, with a slow uneven light
    coarse = rng.normal(0.0, 1.0, (6, 10, 1)).astype(np.float32)
    light = cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC)[..., None]
    image = np.empty((height, width, 3), np.float32)
    image[:] = np.array([196, 182, 160], np.float32)
    image += 10.0 * light
    palette = np.array(
        [[120, 30, 35], [30, 60, 110], [40, 90, 55], [170, 140, 60], [90, 60, 40],
         [200, 200, 190], [60, 60, 70], [150, 80, 40], [100, 40, 90], [210, 170, 120]],
        np.float32,
    )  # fmt: skip
    shelf_gap, board = round(170 * u), max(2, round(14 * u))
    top = round(40 * u)
    while top + shelf_gap < height + shelf_gap:
        y_board = top + shelf_gap - board
        x = round(rng.uniform(0, 30) * u)
        while x < width:
            w = max(2, round(rng.uniform(10, 42) * u))
            h = round(rng.uniform(0.55, 0.92) * (shelf_gap - board))
            if rng.uniform() < 0.12:  # a gap on the shelf
                x += w
                continue
            colour = palette[rng.integers(len(palette))] * rng.uniform(0.75, 1.15)
            y0 = max(y_board - h, 0)
            image[y0:y_board, x : x + w] = colour
            for _ in range(int(rng.integers(0, 3))):  # bands on the spine
                yb = y0 + round(rng.uniform(0.1, 0.8) * h)
                image[yb : yb + max(1, round(3 * u)), x : x + w] = colour * 0.55 + 100
            image[y0:y_board, x : x + max(1, round(u))] *= 0.6  # the spine's edge
            x += w
        image[max(y_board, 0) : top + shelf_gap] = np.array([92, 64, 42], np.float32)
        top += shelf_gap
    image += rng.normal(0.0, 5.0, image.shape).astype(np.float32)
    image = cv2.GaussianBlur(image, (0, 0), 0.8 * u)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def chroma_alpha(frame: np.ndarray) -> np.ndarray:
    """The person's opacity in a GRID frame: 1 on the person, 0 on the blue backdrop.

    Parameters
    ----------
    frame : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 in [0, 1] (see :data:`KEY_LOW`, :data:`KEY_HIGH`), shrunk by
        one pixel (a 3x3 minimum), which takes off the fringe of the backdrop's blue
        about the hair. The top two rows are 0 (GRID's frames begin with a dark line
        and a pale one, not the person; repeated beyond the clip's edge they would show),
        and the sides fade to 0 over 8 columns (a shirt reaching the clip's side would
        otherwise run on sideways beyond it); only the bottom runs on (the torso).
    """
    f = frame.astype(np.float32)
    blue = np.minimum(f[..., 1], f[..., 2]) - f[..., 0]
    alpha = np.clip((KEY_HIGH - blue) / (KEY_HIGH - KEY_LOW), 0.0, 1.0)
    alpha[:_TOP_ROWS] = 0.0
    columns = np.arange(alpha.shape[1], dtype=np.float32)
    sides = np.clip(np.minimum(columns, columns[::-1]) / _SIDE_FADE, 0.0, 1.0)
    return cv2.erode(alpha * sides, np.ones((3, 3), np.uint8))  # the blue fringe off


def hard_frames(
    frames: Iterable[np.ndarray], truth: np.ndarray, background: np.ndarray
) -> Iterator[np.ndarray]:
    """The hard frames: each clip frame keyed, moved by its truth and laid on the background.

    Parameters
    ----------
    frames : iterable of numpy.ndarray
        The clip's ``(h, w, 3)`` uint8 RGB frames.
    truth : numpy.ndarray
        ``(N, 2, 3)`` their maps into the hard frame (:func:`hard_motion`).
    background : numpy.ndarray
        ``(H, W, 3)`` uint8 RGB (:func:`room`).

    Yields
    ------
    numpy.ndarray
        ``(H, W, 3)`` uint8 RGB (bicubic warp of the frame, bilinear of its key; the clip's
        edge rows and columns repeated beyond it, so the shirt runs on below its bottom).
    """
    height, width = background.shape[:2]
    back = background.astype(np.float32)
    for k, frame in enumerate(frames):
        if k >= len(truth):
            raise MiketalkError(f"frame {k} has no truth ({len(truth)} given)")
        m = truth[k]
        moved = cv2.warpAffine(frame, m, (width, height), flags=cv2.INTER_CUBIC,
                               borderMode=cv2.BORDER_REPLICATE)  # fmt: skip
        alpha = cv2.warpAffine(chroma_alpha(frame), m, (width, height), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_REPLICATE)[..., None]  # fmt: skip
        out = back + alpha * (moved.astype(np.float32) - back)
        yield np.clip(np.rint(out), 0, 255).astype(np.uint8)


def make_hard_clip(
    source: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    size: tuple[int, int] = (1280, 720),
    seed: int = 0,
    frames: int | None = None,
    motion: HardMotion | None = None,
    crf: int = 18,
) -> HardClip:
    """Write the hard version of a GRID clip as an mp4 with its sound, and return its truth.

    Parameters
    ----------
    source : str or os.PathLike
        The GRID clip (``.mpg``).
    output : str or os.PathLike
        The mp4 to write.
    size : tuple of int
        The hard frame's ``(width, height)``.
    seed : int
        The room's and the motion's seed.
    frames : int, optional
        Only the first ``frames`` frames.
    motion : HardMotion, optional
        Amplitudes and periods.
    crf : int
        The H.264 quality (18: visually lossless).

    Returns
    -------
    HardClip
    """
    source = Path(source)
    clip, fps = read_video(source, frames=frames)
    truth = hard_motion(len(clip), fps, size=size, seed=seed, name=source.stem, motion=motion)
    audio = read_media_audio(source, rate=_AUDIO_RATE)
    write_mp4(
        output,
        hard_frames(clip, truth, room(size, seed=seed)),
        fps=fps,
        audio=audio,
        rate=_AUDIO_RATE,
        n_frames=len(clip),
        crf=crf,
    )
    return HardClip(Path(output), truth, fps, size)
