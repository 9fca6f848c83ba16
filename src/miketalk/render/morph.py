"""Viseme morphing (paper §5.3-5.4): forward warps, hole-aware blend, hole filling, median.

The morph between images ``I0`` and ``I1`` with correspondence maps ``C0``
(``flow01``, from ``I0`` to ``I1``) and ``C1`` (``flow10``, from ``I1`` to
``I0``) at time ``alpha`` in ``[0, 1]`` is built in four stages:

1. **Forward warps** (Eq. 3-6, Fig. 6). Every pixel ``p = (x, y)`` of ``I0`` is
   pushed to ``RND(p + alpha * C0(p))`` and every pixel of ``I1`` to
   ``RND(p + (1 - alpha) * C1(p))``. ``RND(t) = floor(t + 0.5)`` (halves round
   up). Pixels landing outside the image are dropped. Destination pixels that no
   source pixel reaches are *holes*.
2. **Blend** (Eq. 7 and the hole-aware rule of §5.4). Where both warps reached a
   pixel it gets ``(1 - alpha) * I0w + alpha * I1w``; where only one did, it gets
   that warp's value unblended; where neither did it stays a hole.
3. **Hole filling**: each row is scanned and every run of holes is filled by
   linear interpolation between the non-hole pixels at its two ends (see
   :func:`fill_holes_scanline` for the edge rules).
4. **3x3 median filter** (``cv2.medianBlur``, per channel, replicated borders).

Collision rule
--------------
When several source pixels of one warp land on the same destination pixel, the
one that moves the *farthest* (largest ``|C(p)|``, which for a given warp is the
same order for every ``alpha``) wins: a moving part of the face (a lip sliding
over skin or teeth) is drawn in front of what it moves over, on every side of
it, independently of the scan direction. Ties (e.g. equal motion) go to the
source pixel that comes last in row-major scan order, which is exactly the
paper's Fig. 6 "last write wins". ``collision="scan"`` selects the plain Fig. 6
rule (last in scan order always wins). Both rules are deterministic.

Speed
-----
Both splats, the blend and the hole filling of one frame run in one C function
(``miketalk/render/_morph_kernels.c``, built by ``pip install``; it releases the GIL);
the median is ``cv2.medianBlur``. A C extension rather than numba because a
process pays nothing to load it, where numba took about a second to start:
that second was most of ``miketalk say``'s start-up. The C code computes in
double precision in a fixed order with FMA contraction off, so the frames are
the same bytes on every machine. :class:`Morpher` checks and prepares one pair
once and renders any number of frames from it.

Switching stages off
--------------------
``hole_aware_blend=False`` uses Eq. 7 everywhere, with a hole reading as the
reserved hole colour (black, 0): where one warp left a hole the other warp's
value is darkened by its blend weight (the artefact the rule of §5.4 removes).
``fill_holes=False`` leaves holes black. ``median=False`` skips the median.
:func:`cross_dissolve` is the no-warp baseline.

Bilinear splatting (``splat="bilinear"``, an option, not the paper's): see
:mod:`miketalk.render.splat`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from miketalk.checks import check_flow, check_image
from miketalk.errors import MiketalkError
from miketalk.render.kernels import fill_holes as _fill_holes
from miketalk.render.kernels import render as _render
from miketalk.render.splat import (
    Collision,
    Splat,
    _as_hwc,
    _bilinear_splat,
    _check_alpha,
    _check_collision,
    _check_splat,
    _contiguous,
    _gather,
    _planes,
    _priority,
    _round_u8,
)


def _median3(image: np.ndarray) -> np.ndarray:
    """3x3 median filter of an (H, W, C) uint8 image, per channel."""
    if image.shape[2] == 1:
        return cv2.medianBlur(image[:, :, 0], 3)[:, :, None]
    return cv2.medianBlur(image, 3)


@dataclass(frozen=True)
class MorphStages:
    """Every intermediate image of one morph frame (for figures like the paper's Fig. 7).

    All images have the shape of the input images and dtype uint8; holes are
    :data:`HOLE_VALUE` (black) in ``warp0``, ``warp1`` and ``blend``.

    Attributes
    ----------
    alpha : float
        The morph parameter.
    warp0, hole0 : ndarray
        ``I0`` forward-warped along ``alpha * C0`` and its hole mask (Fig. 7a).
    warp1, hole1 : ndarray
        ``I1`` forward-warped along ``(1 - alpha) * C1`` and its hole mask (Fig. 7b).
    blend, hole : ndarray
        The (hole-aware) blend and the pixels neither warp reached (Fig. 7c).
    filled : ndarray
        ``blend`` after scanline hole filling.
    final : ndarray
        ``filled`` after the 3x3 median: the morph frame (Fig. 7d).
    """

    alpha: float
    warp0: np.ndarray
    hole0: np.ndarray
    warp1: np.ndarray
    hole1: np.ndarray
    blend: np.ndarray
    hole: np.ndarray
    filled: np.ndarray
    final: np.ndarray


class Morpher:
    """One viseme pair, checked and prepared once, rendering morph frames for any alpha.

    Parameters
    ----------
    image0, image1 : ndarray, shape (H, W) or (H, W, 3), uint8
        The two visemes ``I0`` and ``I1``.
    flow01 : ndarray, shape (H, W, 2)
        Correspondence map ``C0``: ``I0(p) ~ I1(p + flow01(p))``.
    flow10 : ndarray, shape (H, W, 2)
        Correspondence map ``C1``: ``I1(p) ~ I0(p + flow10(p))``.
    hole_aware_blend, fill_holes, median : bool, keyword-only
        Switch the refinements of §5.4 on or off (see the module docstring).
    collision : {"motion", "scan"}, keyword-only
        Collision rule of the forward warps (see the module docstring).
    splat : {"nearest", "bilinear"}, keyword-only
        ``"nearest"`` (the default): the paper's rounded forward warp.
        ``"bilinear"``: sources spread bilinearly and averaged (module
        docstring); ``collision`` is then not used.

    Raises
    ------
    MiketalkError
        Naming the argument: a non-uint8 or non-image array, images of different
        shapes, a flow of the wrong size or holding NaN/inf, a bad ``collision``
        or ``splat``.

    Notes
    -----
    Work buffers are reused between frames, so one ``Morpher`` must not be used
    from several threads at once. Returned frames are always new arrays.

    Examples
    --------
    >>> import numpy as np
    >>> image = np.zeros((4, 6), np.uint8); image[:, 2] = 200
    >>> flow = np.zeros((4, 6, 2), np.float32)
    >>> Morpher(image, image, flow, flow, median=False).frame(0.5)[0]
    array([  0,   0, 200,   0,   0,   0], dtype=uint8)
    """

    def __init__(
        self,
        image0: np.ndarray,
        image1: np.ndarray,
        flow01: np.ndarray,
        flow10: np.ndarray,
        *,
        hole_aware_blend: bool = True,
        fill_holes: bool = True,
        median: bool = True,
        collision: Collision = "motion",
        splat: Splat = "nearest",
    ) -> None:
        image0 = check_image(image0, "image0", uint8_only=True)
        image1 = check_image(image1, "image1", uint8_only=True)
        if image1.shape != image0.shape:
            raise MiketalkError(
                f"image1 has shape {image1.shape} but image0 has shape {image0.shape}; "
                "the two visemes must have the same size and number of channels"
            )
        size = image0.shape[:2]
        self._flow0 = _contiguous(check_flow(flow01, "flow01", size), np.float32)
        self._flow1 = _contiguous(check_flow(flow10, "flow10", size), np.float32)
        collision = _check_collision(collision)
        self.splat = _check_splat(splat)
        self.shape: tuple[int, ...] = image0.shape
        self.hole_aware_blend = bool(hole_aware_blend)
        self.fill_holes = bool(fill_holes)
        self.median = bool(median)
        self.collision = collision
        self._image0 = _as_hwc(image0)
        self._image1 = _as_hwc(image1)
        h, w, nc = self._image0.shape
        self._pixels0 = self._image0.reshape(h * w, nc)
        self._pixels1 = self._image1.reshape(h * w, nc)
        self._priority0 = _priority(self._flow0, collision)
        self._priority1 = _priority(self._flow1, collision)
        self._index0 = np.empty((h, w), np.int32)
        self._index1 = np.empty((h, w), np.int32)
        self._depth0 = np.empty((h, w), np.float32)
        self._depth1 = np.empty((h, w), np.float32)
        self._out = np.empty((h, w, nc), np.uint8)
        self._hole = np.empty((h, w), np.bool_)
        self._planes: tuple[np.ndarray, np.ndarray] | None = None  # splat="bilinear" only
        self._warps: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def _blend_bilinear(self, alpha: float) -> None:
        """``splat="bilinear"``: both splats and the blend into the buffers, holes unfilled."""
        if self._planes is None:
            self._planes = (_planes(self._pixels0), _planes(self._pixels1))
        warp0, hole0 = _bilinear_splat(self._planes[0], self._flow0, alpha)
        warp1, hole1 = _bilinear_splat(self._planes[1], self._flow1, 1.0 - alpha)
        blend = (1.0 - alpha) * warp0  # holes hold HOLE_VALUE (0)
        blend += alpha * warp1
        if self.hole_aware_blend:
            only0, only1 = ~hole0 & hole1, hole0 & ~hole1
            blend[only0] = warp0[only0]
            blend[only1] = warp1[only1]
        h, w, nc = self._out.shape
        self._out[...] = _round_u8(blend).reshape(h, w, nc)
        self._hole[...] = (hole0 & hole1).reshape(h, w)
        self._warps = (warp0, hole0, warp1, hole1)

    def _render(self, alpha: float, fill: bool) -> np.ndarray:
        """Run the fused kernel; return the (H, W, C) blend (filled if ``fill``) buffer."""
        if self.splat == "bilinear":
            self._blend_bilinear(alpha)
            complete = _fill_holes(self._out, self._hole) if fill else True
            if not complete:
                self._out[...] = cross_dissolve(self._image0, self._image1, alpha)
            return self._out
        complete = _render(
            self._pixels0,
            self._pixels1,
            self._flow0,
            self._flow1,
            self._priority0,
            self._priority1,
            alpha,
            self.hole_aware_blend,
            fill,
            self._index0,
            self._index1,
            self._depth0,
            self._depth1,
            self._out,
            self._hole,
        )
        if not complete:  # every pixel of both images left the frame: nothing to fill from
            self._out[...] = cross_dissolve(self._image0, self._image1, alpha)
        return self._out

    def frame(self, alpha: float) -> np.ndarray:
        """The morph frame at ``alpha`` (0 gives ``image0``, 1 gives ``image1``).

        Parameters
        ----------
        alpha : float
            Morph parameter in ``[0, 1]``.

        Returns
        -------
        ndarray
            uint8, the shape of ``image0``. With ``fill_holes=True`` it holds no hole.

        Raises
        ------
        MiketalkError
            If ``alpha`` is not a number in ``[0, 1]``.
        """
        alpha = _check_alpha(alpha)
        out = self._render(alpha, self.fill_holes)
        out = _median3(out) if self.median else out.copy()
        return out.reshape(self.shape)

    def frame_and_holes(self, alpha: float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`frame` and the (H, W) bool mask of the pixels neither warp reached.

        One render gives both (the metrics count holes before filling).
        """
        frame = self.frame(alpha)
        return frame, self._hole.copy()

    def frames(self, alphas: Iterable[float]) -> Iterator[np.ndarray]:
        """Yield :meth:`frame` for each alpha in turn."""
        for alpha in alphas:
            yield self.frame(alpha)

    def stages(self, alpha: float) -> MorphStages:
        """Every intermediate image of the frame at ``alpha`` (see :class:`MorphStages`).

        ``hole_aware_blend`` and ``collision`` apply; ``filled`` and ``final`` are
        always computed, whatever ``fill_holes`` and ``median`` say.
        """
        alpha = _check_alpha(alpha)
        blend = self._render(alpha, False).copy()
        hole = self._hole.copy()
        hwc = self._image0.shape
        if self.splat == "bilinear" and self._warps is not None:
            warp0, hole0, warp1, hole1 = self._warps
            warp0, warp1 = _round_u8(warp0), _round_u8(warp1)
            hole0, hole1 = hole0.reshape(hwc[:2]), hole1.reshape(hwc[:2])
        else:
            warp0 = _gather(self._pixels0, self._index0, hwc)
            warp1 = _gather(self._pixels1, self._index1, hwc)
            hole0, hole1 = self._index0 < 0, self._index1 < 0
        filled = blend.copy()
        if not _fill_holes(filled, hole):
            filled[...] = cross_dissolve(self._image0, self._image1, alpha)
        final = _median3(filled)
        return MorphStages(
            alpha=alpha,
            warp0=warp0.reshape(self.shape),
            hole0=hole0.copy(),
            warp1=warp1.reshape(self.shape),
            hole1=hole1.copy(),
            blend=blend.reshape(self.shape),
            hole=hole,
            filled=filled.reshape(self.shape),
            final=final.reshape(self.shape),
        )


def morph(
    image0: np.ndarray,
    image1: np.ndarray,
    flow01: np.ndarray,
    flow10: np.ndarray,
    alpha: float,
    *,
    hole_aware_blend: bool = True,
    fill_holes: bool = True,
    median: bool = True,
    collision: Collision = "motion",
    splat: Splat = "nearest",
) -> np.ndarray:
    """Morph two visemes at ``alpha`` (paper §5.3-5.4).

    Forward-warps ``image0`` along ``alpha * flow01`` and ``image1`` along
    ``(1 - alpha) * flow10``, blends them (hole-aware), fills the remaining holes
    along scanlines and applies a 3x3 median filter. To render many frames of
    one pair use :class:`Morpher`, which does the checks and set-up once.

    Parameters
    ----------
    image0, image1 : ndarray, shape (H, W) or (H, W, 3), uint8
        The visemes ``I0`` and ``I1``.
    flow01, flow10 : ndarray, shape (H, W, 2)
        Correspondence maps ``C0`` (``I0 -> I1``) and ``C1`` (``I1 -> I0``).
    alpha : float
        Morph parameter in ``[0, 1]``.
    hole_aware_blend, fill_holes, median : bool, keyword-only
        Switch the refinements of §5.4 on or off.
    collision : {"motion", "scan"}, keyword-only
        Forward-warp collision rule (module docstring).
    splat : {"nearest", "bilinear"}, keyword-only
        Forward-warp resampling (module docstring); ``"nearest"`` is the paper's.

    Returns
    -------
    ndarray
        The morph frame, uint8, the shape of ``image0``.

    Raises
    ------
    MiketalkError
        Naming the argument, for any malformed input.
    """
    alpha = _check_alpha(alpha)
    morpher = Morpher(
        image0,
        image1,
        flow01,
        flow10,
        hole_aware_blend=hole_aware_blend,
        fill_holes=fill_holes,
        median=median,
        collision=collision,
        splat=splat,
    )
    return morpher.frame(alpha)


def morph_stages(
    image0: np.ndarray,
    image1: np.ndarray,
    flow01: np.ndarray,
    flow10: np.ndarray,
    alpha: float,
    *,
    hole_aware_blend: bool = True,
    collision: Collision = "motion",
    splat: Splat = "nearest",
) -> MorphStages:
    """Every intermediate image of :func:`morph` at ``alpha``, for figures like Fig. 7.

    Parameters are those of :func:`morph`; see :class:`MorphStages` for the result.
    """
    alpha = _check_alpha(alpha)
    morpher = Morpher(
        image0,
        image1,
        flow01,
        flow10,
        hole_aware_blend=hole_aware_blend,
        collision=collision,
        splat=splat,
    )
    return morpher.stages(alpha)


def cross_dissolve(image0: np.ndarray, image1: np.ndarray, alpha: float) -> np.ndarray:
    """Plain cross-dissolve ``(1 - alpha) * image0 + alpha * image1``: the no-warp baseline.

    Parameters
    ----------
    image0, image1 : ndarray, shape (H, W) or (H, W, 3), uint8
        Images of the same shape.
    alpha : float
        Blend parameter in ``[0, 1]``.

    Returns
    -------
    ndarray
        uint8 (rounded half up), the shape of ``image0``.

    Raises
    ------
    MiketalkError
        Naming the argument, for any malformed input.
    """
    image0 = check_image(image0, "image0", uint8_only=True)
    image1 = check_image(image1, "image1", uint8_only=True)
    if image1.shape != image0.shape:
        raise MiketalkError(f"image1 has shape {image1.shape} but image0 has shape {image0.shape}")
    alpha = _check_alpha(alpha)
    mixed = image0 * np.float32(1.0 - alpha) + image1 * np.float32(alpha)
    return np.floor(mixed + np.float32(0.5)).astype(np.uint8)
