"""One light for a face-crop corpus: each clip's colour matched to the reference's.

A person's own video joins shots of other days, rooms and lamps (the weekly addresses:
a pale office, a dark wood panel, bookshelves). A corpus that mixes them draws visemes
and mouths from one light into a face of another: a purple mouth on a brown face. Each
clip of a face-crop corpus (:mod:`miketalk.track`) is therefore matched to the reference
frame, per colour channel, by the gain and offset that carry its median frame's mean and
spread over the face (outside the mouth) onto the reference's (Reinhard et al.'s colour
transfer, 2001, in RGB and over one region): a change of light, not of the face.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_GAIN", "match_light"]

#: The largest gain (and smallest, its inverse) a channel is given: a clip darker or
#: brighter than that is another exposure, matched as far as this and no further.
MAX_GAIN = 2.5


def match_light(
    frames: np.ndarray, reference: np.ndarray, mask: np.ndarray, *, spread: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A clip's frames with its light matched to the reference's over ``mask``.

    Parameters
    ----------
    frames : numpy.ndarray
        ``(N, H, W, 3)`` uint8, stabilized onto the reference.
    reference : numpy.ndarray
        ``(H, W, 3)`` uint8.
    mask : numpy.ndarray
        ``(H, W)`` bool: where the light is measured (the face outside the mouth).
    spread : bool
        Match the spread too (a gain per channel); False: the means only (an offset).

    Returns
    -------
    frames : numpy.ndarray
        ``(N, H, W, 3)`` uint8, each channel ``gain * x + offset``.
    gain, offset : numpy.ndarray
        ``(3,)`` each.
    """
    median = np.median(frames[:: max(1, len(frames) // 15)], axis=0)
    clip = median[mask].astype(np.float64)
    ref = np.asarray(reference)[mask].astype(np.float64)
    gain = np.clip(ref.std(axis=0) / np.maximum(clip.std(axis=0), 1e-3), 1 / MAX_GAIN, MAX_GAIN)
    if not spread:
        gain = np.ones(3)
    offset = ref.mean(axis=0) - gain * clip.mean(axis=0)
    lut = np.clip(np.rint(np.arange(256)[:, None] * gain + offset), 0, 255).astype(np.uint8)
    out = np.empty_like(frames)
    for c in range(3):
        out[..., c] = lut[frames[..., c], c]
    return out, gain, offset
