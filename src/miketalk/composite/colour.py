"""The mouth's colour matched to the frame it is pasted into.

A model's mouth is drawn from frames of other days (its training video, the reference's
light); the frame it is pasted into has its own light. Both ways learn, on the blend's edge
band (skin in the render and in the frame), a smooth per-channel field by normalized
convolution, and bring the render to the frame with it:

- ``"offset"`` (:func:`colour_offset`): ``render + G*(band (frame - render)) / G*band``,
  an additive offset. It brings the skin at the band to the frame's, but carries a change of
  light's brightness and colour onto the lips as a shift: under a dimmer, warmer light the
  reference's pink lips come out grey and dark (the weekly address ``wa05``: Δa* -7 to -9
  against his own lips, docs/anyone.md).
- ``"gain"`` (:func:`colour_gain`): ``render * G*(band frame) / G*(band render)``, a
  per-channel gain (von Kries' model of a change of illuminant; the same gain in the sRGB
  values the render holds and in linear light, since both are powers of each other). It
  keeps each pixel's ratio to the skin beside it: the lips stay as much redder than the
  skin as they were in the model's frames, and the dark mouth stays dark.
- ``"lips"`` (whole backgrounds only, :meth:`~miketalk.composite.compositor.Compositor.
  colour_field`): an additive offset learned over the whole blend region, not its edge, at a
  small scale (:data:`LIPS_SIGMA`), from the model's rest image to the median of the
  background's frames (his own closed-ish mouth in this light): the lips take his lips'
  colour there, the skin his skin's. Matched frame by frame (no median), it would copy the
  frame's own moving mouth, so there it is ``"offset"``.

Measured on the weekly addresses held out, each dubbed with its own recording (docs/anyone.md,
"The mouth's colour"): :data:`miketalk.defaults.BLEND_COLOUR` says which is the default.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["COLOUR_MATCHES", "ColourMatch", "colour_gain", "colour_offset", "match_colour"]

#: The ways a render's colour is matched to a frame's (module docstring).
COLOUR_MATCHES = ("offset", "gain", "lips")

#: ``"lips"``: the Gaussian sigma of its local offset, in mouth widths (the lips are some
#: 0.2 of the mouth's width thick).
LIPS_SIGMA = 0.15

#: A gain is held within ``[1 / GAIN_LIMIT, GAIN_LIMIT]`` (a render nearly black at the band
#: would otherwise give a gain without bound).
GAIN_LIMIT = 4.0


def _spread(values: np.ndarray, band: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """``G * (band values)`` and ``G * band``, with where the second is not empty."""
    weighted = cv2.GaussianBlur(band[..., None] * values, (0, 0), sigma)
    norm = cv2.GaussianBlur(band, (0, 0), sigma)
    ok = norm > 1e-4 * max(float(norm.max()), 1e-12)
    return weighted, norm, ok


def colour_offset(
    render: np.ndarray, frame: np.ndarray, band: np.ndarray, *, sigma: float
) -> np.ndarray:
    """A smooth offset that brings ``render``'s colour to ``frame``'s, learned on ``band``.

    Parameters
    ----------
    render, frame : numpy.ndarray
        (h, w, 3) float32, the same pixels of the render (in the frame's
        coordinates) and of the frame.
    band : numpy.ndarray
        (h, w) float32 weights: where the two should agree (the blend's edge).
    sigma : float
        Gaussian sigma (pixels) of the normalized convolution.

    Returns
    -------
    numpy.ndarray
        (h, w, 3) float32: ``G * (band (frame - render)) / G * band``; zero
        where the band is empty.
    """
    weighted, norm, ok = _spread(frame - render, band, sigma)
    out = np.zeros_like(weighted)
    out[ok] = weighted[ok] / norm[ok, None]
    return out


def colour_gain(
    render: np.ndarray, frame: np.ndarray, band: np.ndarray, *, sigma: float
) -> np.ndarray:
    """A smooth per-channel gain that brings ``render``'s colour to ``frame``'s on ``band``.

    Parameters
    ----------
    render, frame, band, sigma
        As :func:`colour_offset`'s.

    Returns
    -------
    numpy.ndarray
        (h, w, 3) float32: ``G * (band frame) / G * (band render)``, within
        ``[1 / GAIN_LIMIT, GAIN_LIMIT]``; one where the band is empty.
    """
    to, _norm, ok = _spread(frame, band, sigma)
    of, _norm, _ok = _spread(render, band, sigma)
    out = np.ones_like(to)
    ok3 = ok[..., None] & (of > 1e-3)
    np.divide(to, of, out=out, where=ok3)
    return np.clip(out, 1.0 / GAIN_LIMIT, GAIN_LIMIT)


@dataclass(frozen=True)
class ColourMatch:
    """How a render's colour is brought to a frame's: ``render * gain + offset``.

    Attributes
    ----------
    offset : numpy.ndarray
        (h, w, 3) float32 additive field.
    gain : numpy.ndarray or None
        (h, w, 3) float32 per-channel gain (None: one).
    """

    offset: np.ndarray
    gain: np.ndarray | None = None

    def remapped(self, map_x: np.ndarray, map_y: np.ndarray) -> ColourMatch:
        """The same match sampled at ``(map_x, map_y)`` (a field in the reference's
        coordinates carried into a frame's)."""

        def take(field: np.ndarray) -> np.ndarray:
            return cv2.remap(field, map_x, map_y, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)  # fmt: skip

        return ColourMatch(take(self.offset), None if self.gain is None else take(self.gain))

    def apply(self, render: np.ndarray) -> np.ndarray:
        """``render`` (float32, the fields' size) with its colour matched."""
        if self.gain is not None:
            render = render * self.gain
        return render + self.offset


def match_colour(
    render: np.ndarray,
    frame: np.ndarray,
    band: np.ndarray,
    *,
    sigma: float,
    how: str,
    inside: np.ndarray | None = None,
    width: float = 0.0,
) -> ColourMatch:
    """The :class:`ColourMatch` of ``how`` (:data:`COLOUR_MATCHES`) from ``render`` to
    ``frame`` on ``band`` (arguments as :func:`colour_offset`'s); ``"lips"`` learns on
    ``inside`` (the blend's weights) at :data:`LIPS_SIGMA` of the mouth's ``width``, and is
    ``"offset"`` without them."""
    if how == "lips" and inside is not None and width > 0:
        return ColourMatch(colour_offset(render, frame, inside, sigma=LIPS_SIGMA * width))
    if how in ("offset", "lips"):
        return ColourMatch(colour_offset(render, frame, band, sigma=sigma))
    if how == "gain":
        gain = colour_gain(render, frame, band, sigma=sigma)
        return ColourMatch(np.zeros_like(gain), gain)
    raise MiketalkError(
        f"the mouth's colour match must be {' or '.join(COLOUR_MATCHES)}, not {how!r}"
    )
