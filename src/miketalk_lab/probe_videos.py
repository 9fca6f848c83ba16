"""Bad-input probe videos: a talking-head video spoilt as users' videos are.

Each probe is a per-frame change of a source video (:func:`probe_frame`), made while the
frames stream through (:func:`write_probe`), the source's sound kept:

- ``leaves``: the picture slides sideways until the face has left it, stays so, and slides
  back (:func:`shifted`; the uncovered side is filled with the frame's mean colour): a
  camera panned away for a while.
- ``turn`` and ``profile``: the head turned about its own vertical axis (yaw;
  :func:`yaw_turned`), to :data:`PROFILE_DEG` and back for a while, or all along. The
  head is modelled as an upright elliptic cylinder through the face's centre, as wide and
  as deep as a head (:data:`HEAD_HALF_WIDTH`, :data:`HEAD_HALF_DEPTH` eye distances),
  over the rows from the crown to the chin (fading out above and below): each column is
  re-sampled from where the turned cylinder's surface came from, so the far half of the
  face is foreshortened and hidden past the silhouette and the mouth moves towards the
  near one, as in a real turn. It is a
  geometric model of a turn of real pixels, not a photograph of a profile: the nose has
  no relief and the side of the head that comes into view (never in the source) is the
  head's edge column stretched.
- ``roll``: the frame turned 90 degrees in its own plane (a roll, not a profile), scaled
  to the frame's height and centred on its mean colour (:func:`rolled`).
- ``two``: two faces side by side all along, the middle halves of two frames
  (:func:`side_by_side`).
- ``second``: a second face comes into the picture for a while: another frame's face,
  scaled, pasted beside his (:func:`with_second_face`).

A probe's *span* is where it acts (``leaves``, ``turn``, ``second``); ``profile``,
``roll`` and ``two`` act on every frame. :func:`span_weights` is the change's strength
per frame: it ramps in and out over a few frames inside the span, so the frames changed
are exactly the span's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.track import CANONICAL_LANDMARKS, Track, apply_affine, invert_affine

__all__ = [
    "HEAD_HALF_DEPTH",
    "HEAD_HALF_WIDTH",
    "PROBES",
    "PROFILE_DEG",
    "face_geometry",
    "probe_frame",
    "rolled",
    "shifted",
    "side_by_side",
    "span_weights",
    "with_second_face",
    "write_probe",
    "yaw_turned",
]

#: The probes, in the order they are reported.
PROBES = ("leaves", "turn", "profile", "roll", "two", "second")
#: Probes that act within their span only (the others on every frame).
SPANNED = ("leaves", "turn", "second")
#: How far the head is turned in ``turn`` and ``profile`` (degrees of yaw).
PROFILE_DEG = 75.0
#: The head's half width and half depth (front to back) in eye distances (the distance
#: between the eyes' centres): a head is deeper than it is wide.
HEAD_HALF_WIDTH, HEAD_HALF_DEPTH = 1.0, 1.25
#: Rows turned, in eye distances from the eye line (negative: above): fully from the
#: second to the third value, fading to nothing at the first and the last.
HEAD_ROWS = (-2.3, -1.5, 1.8, 2.3)
#: How far ``leaves`` slides the picture at its strongest, as a share of its width.
SHIFT_SHARE = 0.85


def span_weights(n: int, span: tuple[int, int] | None, ramp: int = 6) -> np.ndarray:
    """Per frame, the strength of a change acting in ``span`` (``[start, stop)``), 0 to 1.

    It rises from ``1 / (ramp + 1)`` at ``start`` to 1 over ``ramp`` frames and falls the
    same way to ``stop - 1``: every frame of the span is changed, none outside it. None:
    every frame at full strength.
    """
    if span is None:
        return np.ones(n)
    start, stop = span
    if not 0 <= start < stop <= n:
        raise MiketalkError(f"span {start}-{stop} is not inside the video's {n} frames")
    k = np.arange(n, dtype=np.float64)
    rise = (k - start + 1) / (ramp + 1)
    fall = (stop - k) / (ramp + 1)
    w = np.clip(np.minimum(rise, fall), 0.0, 1.0)
    w[(k < start) | (k >= stop)] = 0.0
    return w


def face_geometry(track: Track) -> np.ndarray:
    """Per frame ``(x, y, d)``: the point between the eyes (frame pixels) and the eye distance.

    From the track's smoothed transforms; a frame left out takes the nearest tracked one's.
    A track with no tracked frame is a :class:`MiketalkError`.
    """
    tracked = np.flatnonzero(track.tracked)
    if not tracked.size:
        raise MiketalkError("the source video shows no tracked face to change")
    out = np.empty((len(track), 3))
    for k in range(len(track)):
        near = tracked[np.abs(tracked - k).argmin()]
        to_frame = invert_affine(track.transforms[near])
        eyes = apply_affine(to_frame, CANONICAL_LANDMARKS[:4])
        left, right = eyes[:2].mean(axis=0), eyes[2:].mean(axis=0)
        out[k] = [*((left + right) / 2), float(np.hypot(*(left - right)))]
    return out


def shifted(frame: np.ndarray, amount: float) -> np.ndarray:
    """The picture slid left by ``amount`` (share of its width, 0 to 1), the uncovered right
    side filled with the frame's mean colour."""
    width = frame.shape[1]
    px = round(float(np.clip(amount, 0.0, 1.0)) * width)
    if px == 0:
        return frame.copy()
    out = np.empty_like(frame)
    out[:, : width - px] = frame[:, px:]
    out[:, width - px :] = frame.reshape(-1, frame.shape[-1]).mean(axis=0).astype(frame.dtype)
    return out


def yaw_turned(frame: np.ndarray, geometry: Sequence[float], degrees: float) -> np.ndarray:
    """The head turned by ``degrees`` of yaw (positive: its face towards the image's right).

    Parameters
    ----------
    frame : numpy.ndarray
        ``(H, W, 3)`` or ``(H, W)`` uint8.
    geometry : sequence of float
        ``(x, y, d)`` of :func:`face_geometry`: between the eyes, and the eye distance.
    degrees : float
        The yaw; 0 returns a copy.

    Returns
    -------
    numpy.ndarray
        The frame with the head's rows re-sampled from the turned cylinder (see the
        module docstring).
    """
    height, width = frame.shape[:2]
    x0, y0, d = (float(v) for v in geometry)
    a, b = HEAD_HALF_WIDTH * d, HEAD_HALF_DEPTH * d
    rows = np.arange(height, dtype=np.float64)
    top0, top1, bottom1, bottom0 = (y0 + t * d for t in HEAD_ROWS)
    strength = np.clip(
        np.minimum((rows - top0) / (top1 - top0), (bottom0 - rows) / (bottom0 - bottom1)), 0, 1
    )
    theta = math.radians(degrees) * strength[:, None]  # (H, 1)
    # a point of the head's outline at angle phi, (a sin phi, b cos phi), turned by theta
    # shows at x = A sin(phi + delta): the silhouette at |x| = A, the near half between
    half = np.hypot(a * np.cos(theta), b * np.sin(theta))
    delta = np.arctan2(b * np.sin(theta), a * np.cos(theta))
    cols = np.arange(width, dtype=np.float64)[None, :]
    u = (cols - x0) / half
    inside = np.abs(u) < 1.0
    came_from = np.clip(np.arcsin(np.clip(u, -1.0, 1.0)) - delta, -math.pi / 2, math.pi / 2)
    map_x = np.where(inside, x0 + a * np.sin(came_from), cols).astype(np.float32)
    map_y = np.broadcast_to(rows[:, None], (height, width)).astype(np.float32)
    return cv2.remap(frame, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def rolled(frame: np.ndarray) -> np.ndarray:
    """The frame turned 90 degrees clockwise, scaled to its height, centred on its mean."""
    height, width = frame.shape[:2]
    turned = cv2.rotate(frame, cv2.ROTATE_90_CLOCKWISE)  # width x height now
    new_w = max(1, round(height * height / width))
    small = cv2.resize(turned, (new_w, height), interpolation=cv2.INTER_AREA)
    out = np.empty_like(frame)
    out[:] = frame.reshape(-1, frame.shape[-1]).mean(axis=0).astype(frame.dtype)
    left = (width - new_w) // 2
    out[:, left : left + new_w] = small
    return out


def side_by_side(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The middle halves of two frames of one size, ``a``'s on the left."""
    width = a.shape[1]
    quarter, half = width // 4, width // 2
    return np.concatenate([a[:, quarter : quarter + half], b[:, quarter : quarter + width - half]],
                          axis=1)  # fmt: skip


def with_second_face(
    frame: np.ndarray, other: np.ndarray, geometry: Sequence[float],
    other_geometry: Sequence[float], weight: float,
) -> np.ndarray:  # fmt: skip
    """``other``'s face (a box of 4 by 5 eye distances around it) pasted at 0.8 of its size,
    three head widths to the right of the face of ``frame`` (or to the left when that is
    outside the frame), faded in by ``weight`` (0 to 1)."""
    if weight <= 0:
        return frame.copy()
    height, width = frame.shape[:2]
    x0, y0, d0 = (float(v) for v in geometry)
    x1, y1, d1 = (float(v) for v in other_geometry)
    scale = 0.8 * d0 / d1
    half_w, half_h = 2.0 * d1, 2.5 * d1
    box = other[
        max(0, round(y1 - 0.9 * half_h)) : min(height, round(y1 + 1.1 * half_h)),
        max(0, round(x1 - half_w)) : min(width, round(x1 + half_w)),
    ]
    size = (max(1, round(box.shape[1] * scale)), max(1, round(box.shape[0] * scale)))
    patch = cv2.resize(box, size, interpolation=cv2.INTER_AREA)
    ph, pw = patch.shape[:2]
    cx = x0 + 6 * HEAD_HALF_WIDTH * d0
    if cx + pw / 2 > width:
        cx = x0 - 6 * HEAD_HALF_WIDTH * d0
    left = int(np.clip(round(cx - pw / 2), 0, max(0, width - pw)))
    top = int(np.clip(round(y0 - 0.9 * half_h * scale), 0, max(0, height - ph)))
    ph, pw = min(ph, height - top), min(pw, width - left)
    out = frame.copy()
    region = out[top : top + ph, left : left + pw].astype(np.float32)
    mixed = (1 - weight) * region + weight * patch[:ph, :pw].astype(np.float32)
    out[top : top + ph, left : left + pw] = np.round(mixed).astype(frame.dtype)
    return out


def probe_frame(
    name: str, frame: np.ndarray, weight: float, geometry: Sequence[float], *,
    other: np.ndarray | None = None, other_geometry: Sequence[float] | None = None,
) -> np.ndarray:  # fmt: skip
    """One frame of probe ``name`` (:data:`PROBES`) at strength ``weight`` (0 to 1).

    ``geometry`` is the frame's :func:`face_geometry` row; ``two`` and ``second`` also take
    ``other`` (the other face's frame) and ``second`` its geometry.
    """
    if name == "leaves":
        return shifted(frame, SHIFT_SHARE * weight)
    if name in ("turn", "profile"):
        return yaw_turned(frame, geometry, PROFILE_DEG * weight)
    if name == "roll":
        return rolled(frame)
    if name in ("two", "second") and other is None:
        raise MiketalkError(f"the probe {name!r} needs the other face's frame")
    if name == "two":
        return side_by_side(frame, other)
    if name == "second":
        if other_geometry is None:
            raise MiketalkError("the probe 'second' needs the other face's geometry")
        return with_second_face(frame, other, geometry, other_geometry, weight)
    raise MiketalkError(f"no probe {name!r}: one of {', '.join(PROBES)}")


def write_probe(
    path: str | Path, name: str, frames: Callable[[], Iterable[np.ndarray]],
    geometry: np.ndarray, *, fps: float, audio: np.ndarray, rate: int,
    span: tuple[int, int] | None = None, other_offset: int = 0, crf: int = 18,
) -> np.ndarray:  # fmt: skip
    """Write probe ``name`` of a source video as an mp4 with the source's sound.

    Parameters
    ----------
    path : path-like
        The mp4 to write (atomically, :func:`miketalk.media.video.write_mp4`).
    name : str
        One of :data:`PROBES`.
    frames : callable
        Returns a fresh iterable of the source's frames (called twice for ``two`` and
        ``second``: the other face is the source itself ``other_offset`` frames later,
        cyclically).
    geometry : numpy.ndarray
        ``(N, 3)`` the source's :func:`face_geometry`.
    fps, audio, rate
        The source's frame rate and sound (mono int16 at ``rate`` Hz).
    span : tuple of int, optional
        ``[start, stop)`` frames where the probe acts (:data:`SPANNED` probes: required).
    other_offset : int
        How far the other face runs ahead of the source (frames).
    crf : int
        x264's constant rate factor.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` the change's strength per frame (:func:`span_weights`; 0: untouched).
    """
    from miketalk.media.video import write_mp4

    n = len(geometry)
    if name in SPANNED and span is None:
        raise MiketalkError(f"the probe {name!r} needs a span of frames")
    weights = span_weights(n, span if name in SPANNED else None)

    def others() -> Iterator[np.ndarray | None]:
        if name not in ("two", "second"):
            while True:
                yield None
        skip = other_offset % n
        while True:  # the source again, ``skip`` frames on, from its start when it ends
            for k, frame in enumerate(frames()):
                if k >= skip:
                    yield frame
            skip = 0

    def made() -> Iterator[np.ndarray]:
        for k, (frame, other) in enumerate(zip(frames(), others(), strict=False)):
            if k >= n:
                return
            if weights[k] == 0:
                yield frame
                continue
            j = (k + other_offset) % n
            yield probe_frame(name, frame, float(weights[k]), geometry[k], other=other,
                              other_geometry=geometry[j])  # fmt: skip

    write_mp4(path, made(), fps=fps, audio=audio, rate=rate, n_frames=n, crf=crf)
    return weights
