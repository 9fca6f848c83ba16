"""A mouth rendered in the reference frame, composited into a video frame of the person.

The model draws every frame in the *reference* frame's coordinates (the
corpus's stabilized frames). A video frame of the same person shows reference
pixel ``p`` at ``T @ (p + F(p), 1)``, where ``T`` is the frame's affine
stabilization transform and ``F`` the clip's smooth conform field
(:meth:`miketalk.stabilize.Stabilizer.register`, ``conform``). So
compositing is that mapping run backwards: for each pixel ``q`` of the frame
near the mouth, ``u = T^-1 q`` and ``p = u - F(p)`` (two fixed-point steps:
the field is smooth and a few pixels at most), and the render is sampled at
``p`` (bicubic by default: the render was itself resampled once, from the
corpus's video, and two bilinear samplings soften the mouth visibly).

The blend (:func:`blend_mask`) is an ellipse about the mouth box from just
below the nose to past the chin, wide enough for the jaw line beside the
chin, with a Gaussian edge: inside it the render, outside the frame, so the
lips, the chin and the jaw move together and the nose, the eyes and the rest
of the head are the frame's own. Before blending, the render's colour is
matched to the frame's (:mod:`miketalk.composite.colour`): frame and render
in the blend's edge band (skin in both) are spread over the region by
normalized convolution, a smooth per-channel gain (or offset) that follows a
lighting gradient, as the guidance field of Poisson blending would.

Where the real jaw opens more or less than the synthesized one, its line would
show twice at the mask's edge (the frame's jaw outside, the render's inside: a dark
notch on the jaw line). With ``follow`` (the default) the frame's lower face around
the mask is first warped to follow the render (:func:`follow_render`): the dense
flow (DIS) from the render to the frame over the region, smoothed, moves the frame's
pixels by it with a weight that is one at the mask's edge below the mouth and fades
out over half a mouth width beyond it and above the mouth, so the jaw line outside
the mask continues the render's inside it.

``blend="poisson"`` uses ``cv2.seamlessClone`` instead. On s1's 8 held-out clips dubbed
with their own audio it scores a higher whole-frame PSNR (40.2 against 39.2 dB) and a seam
gradient ratio nearer 1 (0.99 against 0.93), but the mouth's opening stops following the
synthesized mouth (its correlation with the real opening over the speech 0.16 against
0.65): the gradient-domain blend takes each frame's level from the border, where the real
jaw moves. So the feathered blend is the default.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from miketalk import defaults
from miketalk.composite.colour import COLOUR_MATCHES, ColourMatch, colour_offset, match_colour
from miketalk.composite.follow import follow_render, skin_weight
from miketalk.errors import MiketalkError

__all__ = [
    "INTERPOLATIONS",
    "Compositor",
    "Placement",
    "blend_mask",
    "colour_offset",
    "follow_render",
    "place",
    "skin_weight",
]

Box = tuple[int, int, int, int]

#: Fixed-point steps inverting ``p + F(p)`` (the conform field moves a few pixels).
_FIELD_STEPS = 3

#: Alpha below which a pixel of the blend mask counts as outside it.
_EMPTY = 1e-3

#: The OpenCV interpolation of each :class:`Compositor` ``interpolation``.
INTERPOLATIONS = {"linear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC}


def blend_mask(
    mouth_box: Box,
    size: tuple[int, int],
    *,
    half_width: float = defaults.BLEND_HALF_WIDTH,
    above: float = defaults.BLEND_ABOVE,
    below: float = defaults.BLEND_BELOW,
    chin_width: float = defaults.BLEND_CHIN_WIDTH,
    feather: float = defaults.BLEND_FEATHER,
) -> np.ndarray:
    """Where the render replaces the frame, in the reference's coordinates.

    Parameters
    ----------
    mouth_box : tuple of int
        ``(x, y, w, h)`` where the lips move most (the corpus's mouth box).
    size : tuple of int
        ``(H, W)`` of the reference.
    half_width, above, below : float
        The ellipse where the alpha is one half, in mouth widths ``w`` about
        the box's centre: half its width, how far above the centre it starts
        and how far below it ends.
    chin_width : float
        Half the width of its lower half (an egg: the jaw line beside the
        mouth, the chin below it, not the neck beside the chin).
    feather : float
        Gaussian sigma of the edge, in mouth widths.

    Returns
    -------
    numpy.ndarray
        (H, W) float32 alpha in [0, 1]: one over the lips and the chin, zero
        beyond about three sigmas outside the ellipse.
    """
    x, y, w, _h = mouth_box
    if w <= 0:
        raise MiketalkError(f"the mouth box {mouth_box} has no width")
    cx, cy = x + w / 2, y + _h / 2
    top, bottom = cy - above * w, cy + below * w
    mask = np.zeros(size, np.uint8)
    centre = (round(cx * 16), round((top + bottom) / 2 * 16))  # 4 fractional bits
    height = round((bottom - top) / 2 * 16)
    cv2.ellipse(mask, centre, (round(half_width * w * 16), height), 0, 180, 360, 255, -1,
                cv2.LINE_AA, shift=4)  # fmt: skip
    cv2.ellipse(mask, centre, (round(chin_width * w * 16), height), 0, 0, 180, 255, -1,
                cv2.LINE_AA, shift=4)  # fmt: skip
    alpha = cv2.GaussianBlur(mask.astype(np.float32) / 255, (0, 0), feather * w)
    alpha[alpha < _EMPTY] = 0
    return alpha


@dataclass(frozen=True)
class Placement:
    """Where the blend region lands in one frame.

    Attributes
    ----------
    box : tuple of int
        ``(x0, y0, x1, y1)``: the frame's pixels the blend may touch.
    map_x, map_y : numpy.ndarray
        (y1 - y0, x1 - x0) float32: the reference pixel each of them shows.
    alpha : numpy.ndarray
        (y1 - y0, x1 - x0) float32: the blend mask there.
    """

    box: tuple[int, int, int, int]
    map_x: np.ndarray
    map_y: np.ndarray
    alpha: np.ndarray

    def full_alpha(self, shape: tuple[int, int]) -> np.ndarray:
        """The blend mask over a whole ``(H, W)`` frame (float32)."""
        out = np.zeros(shape, np.float32)
        x0, y0, x1, y1 = self.box
        out[y0:y1, x0:x1] = self.alpha
        return out


def place(
    alpha: np.ndarray,
    transform: np.ndarray,
    frame_shape: tuple[int, int],
    *,
    field: np.ndarray | None = None,
    support: Box | None = None,
) -> Placement | None:
    """Carry the blend region into a frame: the inverse of the frame's stabilization.

    Parameters
    ----------
    alpha : numpy.ndarray
        (H, W) float32 blend mask in the reference (:func:`blend_mask`).
    transform : numpy.ndarray
        (2, 3): reference pixel ``(x, y)`` shows in the frame at
        ``T @ (x + F_x, y + F_y, 1)``.
    frame_shape : tuple of int
        ``(H, W)`` of the frame.
    field : numpy.ndarray, optional
        (H, W, 2) float32 conform field ``F`` of the frame's clip.
    support : tuple of int, optional
        ``(x, y, w, h)`` of ``alpha``'s non-zero part (found when not given).

    Returns
    -------
    Placement or None
        None when the region falls outside the frame.
    """
    t = np.asarray(transform, np.float64)
    if t.shape != (2, 3) or not np.isfinite(t).all():
        raise MiketalkError(f"a stabilization transform is a finite (2, 3) matrix, got {t}")
    if support is None:
        support = cv2.boundingRect((alpha > 0).astype(np.uint8))
    sx, sy, sw, sh = support
    pad = 2.0 + (float(np.abs(field).max()) if field is not None else 0.0)
    corners = np.array(
        [[sx - pad, sy - pad], [sx + sw + pad, sy - pad], [sx - pad, sy + sh + pad],
         [sx + sw + pad, sy + sh + pad]]
    )  # fmt: skip
    landed = corners @ t[:, :2].T + t[:, 2]
    h, w = frame_shape
    x0, y0 = np.floor(landed.min(axis=0)).astype(int)
    x1, y1 = np.ceil(landed.max(axis=0)).astype(int) + 1
    x0, y0, x1, y1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
    if x1 <= x0 or y1 <= y0:
        return None
    qy, qx = np.mgrid[y0:y1, x0:x1].astype(np.float64)
    inverse = cv2.invertAffineTransform(t)
    ux = inverse[0, 0] * qx + inverse[0, 1] * qy + inverse[0, 2]
    uy = inverse[1, 0] * qx + inverse[1, 1] * qy + inverse[1, 2]
    px, py = ux.astype(np.float32), uy.astype(np.float32)
    if field is not None:
        ux32, uy32 = px.copy(), py.copy()
        for _ in range(_FIELD_STEPS):  # p = u - F(p)
            f = cv2.remap(field, px, py, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            px, py = ux32 - f[..., 0], uy32 - f[..., 1]
    placed = cv2.remap(alpha, px, py, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    return Placement((int(x0), int(y0), int(x1), int(y1)), px, py, placed)


class Compositor:
    """Blend renders in the reference's coordinates into frames of the person.

    Parameters
    ----------
    mouth_box : tuple of int
        ``(x, y, w, h)`` of the mouth in the reference.
    size : tuple of int
        ``(H, W)`` of the reference (and of the renders).
    colour_match : bool
        Match the render's colour to each frame's (:mod:`miketalk.composite.colour`).
    colour : {"offset", "gain", "lips"}, optional
        How (:func:`~miketalk.composite.colour.match_colour`; None:
        :data:`miketalk.defaults.BLEND_COLOUR`, whose docstring holds its measure).
    blend : {"feather", "poisson"}
        ``"feather"``: alpha blending over the mask's Gaussian edge;
        ``"poisson"``: ``cv2.seamlessClone`` (Poisson image editing, Perez et
        al. 2003) of the render inside the mask's half-alpha contour, the
        frame's own pixels on its border.
    follow : bool
        Warp the frame's lower face about the mask to follow the render
        (:func:`follow_render`) before blending.
    follow_within : numpy.ndarray, optional
        (H, W) float32 in [0, 1] in the reference's coordinates: where that warp may move
        the frame's pixels (None: wherever its weight reaches, half a mouth width beyond
        the mask). A face crop's keep (its jaw ellipse and skin) holds it inside the face,
        off a textured room beside the jaw.
    keep : numpy.ndarray, optional
        (H, W) float32 in [0, 1] multiplied into the blend mask: where the render may show
        (:func:`skin_weight`: not its backdrop or clothes).
    interpolation : {"cubic", "linear"}
        How the render is sampled at the frame's pixels (:data:`INTERPOLATIONS`); the
        default's measured case is in :data:`miketalk.defaults.BLEND_INTERPOLATION`.
    **mask
        Keyword settings of :func:`blend_mask`.
    """

    def __init__(
        self,
        mouth_box: Box,
        size: tuple[int, int],
        *,
        colour_match: bool = True,
        colour: str | None = None,
        blend: str = "feather",
        follow: bool = defaults.BLEND_FOLLOW,
        keep: np.ndarray | None = None,
        interpolation: str = defaults.BLEND_INTERPOLATION,
        follow_within: np.ndarray | None = None,
        **mask: float,
    ) -> None:
        if blend not in ("feather", "poisson"):
            raise MiketalkError(f"blend must be feather or poisson, not {blend!r}")
        if interpolation not in INTERPOLATIONS:
            raise MiketalkError(
                f"interpolation must be {' or '.join(INTERPOLATIONS)}, not {interpolation!r}"
            )
        colour = colour or defaults.BLEND_COLOUR
        if colour not in COLOUR_MATCHES:
            raise MiketalkError(
                f"the mouth's colour match must be {' or '.join(COLOUR_MATCHES)}, not {colour!r}"
            )
        self.colour = colour
        self.interpolation = interpolation
        self.blend = blend
        self.mouth_box = tuple(int(v) for v in mouth_box)
        self.size = (int(size[0]), int(size[1]))
        self.alpha = blend_mask(self.mouth_box, self.size, **mask)
        if keep is not None:
            self.alpha = self.alpha * np.asarray(keep, np.float32)
            self.alpha[self.alpha < _EMPTY] = 0
        self.support = cv2.boundingRect((self.alpha > 0).astype(np.uint8))
        self.colour_match = colour_match
        self.follow = follow
        self.follow_within = (
            None if follow_within is None else np.asarray(follow_within, np.float32)
        )
        self._sigma = 0.5 * self.mouth_box[2]

    def place(
        self,
        transform: np.ndarray,
        frame_shape: tuple[int, int],
        *,
        field: np.ndarray | None = None,
    ) -> Placement | None:
        """:func:`place` of this compositor's blend mask."""
        return place(self.alpha, transform, frame_shape, field=field, support=self.support)

    def colour_field(self, render: np.ndarray, steady: np.ndarray) -> ColourMatch:
        """One colour match for a whole background, in the reference's coordinates.

        Parameters
        ----------
        render : numpy.ndarray
            (H, W, 3) a typical render (the model's silence image).
        steady : numpy.ndarray
            (H, W, 3) the background's frames stabilized onto the reference,
            their median.

        Returns
        -------
        ColourMatch
            (H, W, 3) fields of this compositor's :attr:`colour` way
            (:func:`~miketalk.composite.colour.match_colour`) of the two on the blend's
            edge band: constant over the background, so the colour of the
            mouth does not flicker with what the frames' own jaw does there.
        """
        band = 4.0 * self.alpha * (1.0 - self.alpha)
        return match_colour(render.astype(np.float32), steady.astype(np.float32), band,
                            sigma=self._sigma, how=self.colour, inside=self.alpha,
                            width=float(self.mouth_box[2]))  # fmt: skip

    def __call__(
        self,
        frame: np.ndarray,
        render: np.ndarray,
        transform: np.ndarray,
        *,
        field: np.ndarray | None = None,
        offset: ColourMatch | np.ndarray | None = None,
    ) -> np.ndarray:
        """``render`` blended into a copy of ``frame`` where the mouth is.

        Parameters
        ----------
        frame : numpy.ndarray
            (H', W', 3) uint8 RGB, a frame of the person (any size).
        render : numpy.ndarray
            (H, W, 3) uint8 RGB in the reference's coordinates.
        transform : numpy.ndarray
            (2, 3) the frame's stabilization transform.
        field : numpy.ndarray, optional
            (H, W, 2) the conform field of the frame's clip.
        offset : ColourMatch or numpy.ndarray, optional
            The colour match in the reference's coordinates (:meth:`colour_field`; an
            array: an additive offset), used instead of matching this frame's colour.

        Returns
        -------
        numpy.ndarray
            (H', W', 3) uint8.
        """
        out = np.array(frame, np.uint8, copy=True)
        blended = self.blend_box(frame, render, transform, field=field, offset=offset)
        if blended is not None:
            (x0, y0, x1, y1), pixels = blended
            out[y0:y1, x0:x1] = pixels
        return out

    def blend_box(
        self,
        frame: np.ndarray,
        render: np.ndarray,
        transform: np.ndarray,
        *,
        field: np.ndarray | None = None,
        offset: np.ndarray | None = None,
        placement: Placement | None = None,
    ) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
        """What :meth:`__call__` changes, and only that: the frame's box ``(x0, y0, x1, y1)``
        the blend touches and its pixels there, (y1 - y0, x1 - x0, 3) uint8 (None: the
        mouth falls outside the frame, nothing changes). Only the box is read from
        ``frame`` (a mapped frame is not read whole); ``placement``: :meth:`place`'s, made
        before (a background frame's, kept)."""
        if render.shape[:2] != self.size:
            raise MiketalkError(
                f"the render is {render.shape[1]}x{render.shape[0]}, the reference "
                f"{self.size[1]}x{self.size[0]}"
            )
        if placement is None:
            placement = self.place(transform, frame.shape[:2], field=field)
        if placement is None:
            return None
        x0, y0, x1, y1 = placement.box
        mouth = cv2.remap(
            render, placement.map_x, placement.map_y, INTERPOLATIONS[self.interpolation],
            borderMode=cv2.BORDER_REPLICATE,
        ).astype(np.float32)  # fmt: skip
        here = np.asarray(frame[y0:y1, x0:x1], np.float32)
        a = placement.alpha[..., None]
        if offset is not None:
            match = offset if isinstance(offset, ColourMatch) else ColourMatch(offset)
            mouth = match.remapped(placement.map_x, placement.map_y).apply(mouth)
        elif self.colour_match:
            band = 4.0 * placement.alpha * (1.0 - placement.alpha)
            mouth = match_colour(mouth, here, band, sigma=self._sigma, how=self.colour).apply(mouth)
        if self.follow:
            within = None
            if self.follow_within is not None:
                within = cv2.remap(
                    self.follow_within, placement.map_x, placement.map_y, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT,
                )  # fmt: skip
            here = follow_render(here, mouth, placement.alpha, placement.map_y, self.mouth_box,
                                 within=within)  # fmt: skip
        if self.blend == "poisson":
            out = np.array(frame, np.uint8, copy=True)
            if self.follow:  # the frame the mouth is cloned into, its jaw moved
                out[y0:y1, x0:x1] = np.clip(here + 0.5, 0, 255).astype(np.uint8)
            cloned = _seamless(out, np.clip(mouth + 0.5, 0, 255).astype(np.uint8), placement)
            return placement.box, cloned[y0:y1, x0:x1]
        blended = here + a * (mouth - here)
        return placement.box, np.clip(blended + 0.5, 0, 255).astype(np.uint8)


def _seamless(frame: np.ndarray, mouth: np.ndarray, placement: Placement) -> np.ndarray:
    """``cv2.seamlessClone`` of ``mouth`` (the placement's box) into ``frame`` where alpha > 1/2."""
    x0, y0 = placement.box[:2]
    inside = np.where(placement.alpha > 0.5, 255, 0).astype(np.uint8)
    inside[[0, -1], :] = 0  # seamlessClone needs the mask inside the source
    inside[:, [0, -1]] = 0
    if not inside.any():
        return frame
    bx, by, bw, bh = cv2.boundingRect(inside)
    centre = (x0 + bx + bw // 2, y0 + by + bh // 2)
    return cv2.seamlessClone(mouth, frame, inside, centre, cv2.NORMAL_CLONE)
