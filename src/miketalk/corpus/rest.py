"""The bridge strategy: flow between far-apart visemes through the recording's rest frames.

The paper's mixed strategy (section 5.2) looks for an intermediate frame that
"is simultaneously similar in shape to the chosen starting viseme, and also
close in distance to the chosen ending viseme", searching only a few frames
before the end viseme. In a corpus of words spoken one at a time, such a
frame is almost never there: the end viseme's word starts from the rest pose,
and nothing near it looks like, say, a wide-open \\aa\\. What the corpus does
offer is the rest pose itself, held in every pause. Two rest frames look
alike wherever they are in the recording, so a direct flow between them is
short and reliable. The bridge is

    C_{A,B} = concat( C_{a, r_a}, C_{r_a, r_b}, C_{r_b, b} )

with ``a`` and ``b`` the frames of visemes A and B, ``r_a`` and ``r_b`` the
rest frames nearest to them in time, ``C_{a, r_a}`` and ``C_{r_b, b}``
concatenated consecutive flows of the recording (a dozen small motions each,
where a gradient-based estimator is at its best) and ``C_{r_a, r_b}`` one
direct flow between two rest frames.

Rest frames are found from the recording alone: the frames whose mean
absolute grey-level difference to the silence viseme's frame, over the part of
the picture that moves most in the recording (the mouth and jaw), is within
``tolerance`` of the spread between the 10th percentile of those differences
(the noise floor: a corpus rests in its pauses for a good part of the time)
and their median (a typical speaking frame).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import cv2
import numpy as np

from miketalk.errors import MiketalkError


def motion_region(grey: np.ndarray, *, fraction: float = 0.3, block: int = 4096) -> np.ndarray:
    """The pixels that vary most over a recording: ``(H, W)`` bool.

    ``grey`` is ``(N, H, W)``, uint8 or float32. The per-pixel standard deviation
    over time (in float32), smoothed, above ``fraction`` of its maximum. It is
    measured ``block`` pixels at a time, so that a long recording's frames are
    never copied whole.
    """
    flat = grey.reshape(len(grey), -1)
    spread = np.empty(flat.shape[1], np.float32)
    for start in range(0, flat.shape[1], block):
        spread[start : start + block] = flat[:, start : start + block].std(axis=0, dtype=np.float32)
    spread = cv2.GaussianBlur(spread.reshape(grey.shape[1:]), (0, 0), 2.0)
    return spread > fraction * spread.max()


def rest_frames(
    frames: Sequence[np.ndarray], silence_frame: int, *, tolerance: float = 0.1, block: int = 1024
) -> np.ndarray:
    """Indices of the frames that show the rest pose (the silence viseme), ascending.

    Parameters
    ----------
    frames : sequence of ndarray, shape (H, W) or (H, W, 3), uint8
        The whole recording.
    silence_frame : int
        The silence viseme's frame.
    tolerance : float
        How far above the noise floor a rest frame may be, as a fraction of
        the spread between the floor and a typical frame (see the module
        docstring).
    block : int
        Frames measured at a time (the recording is held once, as half-size grey
        uint8: 10 minutes at 25 fps of 360x288 frames in 389 MB).

    Returns
    -------
    ndarray of int
        Always holds ``silence_frame``.
    """
    if not 0 <= silence_frame < len(frames):
        raise MiketalkError(
            f"silence_frame {silence_frame} is outside the recording (0..{len(frames) - 1})"
        )
    if not tolerance >= 0:
        raise MiketalkError(f"tolerance must be >= 0, got {tolerance!r}")
    grey = grey_stack((_grey_half(f) for f in frames), len(frames))
    region = motion_region(grey)
    silence = grey[silence_frame, region].astype(np.float32)
    distance = np.concatenate(
        [
            np.abs(grey[start : start + block, region].astype(np.float32) - silence).mean(axis=1)
            for start in range(0, len(grey), block)
        ]
    )
    floor, typical = np.percentile(distance, [10, 50])
    rest = np.flatnonzero(distance <= floor + tolerance * (typical - floor))
    return np.union1d(rest, [silence_frame]).astype(int)


def nearest_rest(frame: int, rest: np.ndarray) -> int:
    """The rest frame nearest to ``frame`` in time (the earlier one on a tie)."""
    return int(rest[np.argmin(np.abs(rest - frame))])


def grey_stack(images: Iterable[np.ndarray], count: int) -> np.ndarray:
    """``(count, H, W)``: ``count`` grey images of one size and dtype, stacked as they come
    (a list of them and ``np.stack`` of it would hold them twice)."""
    out, filled = None, 0
    for image in images:
        if out is None:
            out = np.empty((count, *image.shape), image.dtype)
        if filled == count:
            raise MiketalkError(f"more than the {count} frames expected")
        out[filled] = image
        filled += 1
    if out is None:
        raise MiketalkError("no frames to stack")
    if filled < count:
        raise MiketalkError(f"{filled} frames where {count} were expected")
    return out


def _grey_half(image: np.ndarray) -> np.ndarray:
    """Half-size grey: uint8 for a uint8 image (INTER_AREA keeps the type), else float32."""
    image = np.asarray(image)
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
    half = cv2.resize(grey, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
    return half if half.dtype == np.uint8 else half.astype(np.float32)
