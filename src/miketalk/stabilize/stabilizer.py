"""The stabilizer: every frame of a clip registered to one reference frame, conformed and warped."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.stabilize.conform import ConformBasis
from miketalk.stabilize.ecc import _aligned_box, _ecc, _hom, _Level, _to_level
from miketalk.stabilize.locate import (
    Box,
    Region,
    _check_frame,
    _disk,
    _extent,
    _eye_rows,
    _gray,
    locate_face,
    locate_mouth,
    registration_mask,
)
from miketalk.stabilize.warp import warp_to_reference

#: :attr:`Stabilizer.correlations` of a frame whose ECC did not converge.
NOT_CONVERGED = -1.0


@dataclass(frozen=True)
class Stabilized:
    """A clip registered to the reference: :meth:`Stabilizer.stabilize`'s result.

    Attributes
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8, the stabilized frames.
    transforms : numpy.ndarray
        (N, 2, 3) affine maps from reference pixel coordinates to the frame's.
    field : numpy.ndarray or None
        (H, W, 2) float32 conform field (reference pixel offsets), or None.
    correlations : numpy.ndarray
        (N,) ECC correlation coefficient of each frame.
    """

    frames: np.ndarray
    transforms: np.ndarray
    field: np.ndarray | None
    correlations: np.ndarray


class Stabilizer:
    """Registers frames to one reference frame on a mask (the face outside the mouth).

    Parameters
    ----------
    reference : numpy.ndarray
        (H, W, 3) uint8 RGB (or (H, W)) reference frame.
    mask : numpy.ndarray
        (H, W) bool, where to register (:func:`registration_mask`).
    levels : int
        Pyramid levels (2: half size, then full size).
    iterations : tuple of int
        ECC iteration limit per level, coarse to fine.
    epsilon : float
        ECC stops when the correlation improves by less than this.
    blur : int
        ECC's Gaussian pre-filter size (odd; MPEG noise).
    search : int
        How far (full-size pixels) beyond the mask the frame is searched.
    min_correlation : float
        Below this ECC correlation coefficient a frame does not register.
    interpolation : int
        OpenCV interpolation for :meth:`apply` (``cv2.INTER_LINEAR``).
    conform_degree : int
        Degree of the polynomial conform field (0: no field).
    max_conform : float
        Largest conform offset, in widths of the conform mask, before a clip
        is taken not to show the reference's face.
    outlier_factor : float
        After ECC, pixels whose normalized difference from the reference
        exceeds this many times the median are left out and ECC runs once
        more at full size (0: no second run).
    conform_mask : numpy.ndarray, optional
        (H, W) bool, where :meth:`conform` fits its field (``mask`` by
        default; :meth:`from_reference` gives the face below the brows
        outside the mouth zone).

    Attributes
    ----------
    correlations : numpy.ndarray
        The last :meth:`register` call's per-frame ECC correlations.
    face, mouth_box : set by :meth:`from_reference` (None otherwise).
    """

    def __init__(
        self,
        reference: np.ndarray,
        mask: np.ndarray,
        *,
        levels: int = 2,
        iterations: tuple[int, ...] = (30, 15),
        epsilon: float = 1e-4,
        blur: int = 5,
        search: int = 32,
        min_correlation: float = 0.8,
        interpolation: int = cv2.INTER_LINEAR,
        conform_degree: int = 3,
        max_conform: float = 0.25,
        outlier_factor: float = 3.0,
        conform_mask: np.ndarray | None = None,
    ) -> None:
        self.reference = np.asarray(reference)
        self.mask = np.asarray(mask, bool)
        if self.reference.shape[:2] != self.mask.shape:
            raise MiketalkError(
                f"mask {self.mask.shape} and reference {self.reference.shape[:2]} differ in size"
            )
        if levels < 1:
            raise MiketalkError(f"levels must be at least 1, got {levels}")
        self.min_correlation = min_correlation
        self.interpolation = interpolation
        self.conform_degree = conform_degree
        self.max_conform = max_conform
        self.outlier_factor = outlier_factor
        self.conform_mask = self.mask if conform_mask is None else np.asarray(conform_mask, bool)
        if self.conform_mask.shape != self.mask.shape or not self.conform_mask.any():
            raise MiketalkError("conform_mask must be a non-empty mask of the reference's size")
        self.blur = blur
        self.correlations = np.empty(0)
        self.face: np.ndarray | None = None
        self.mouth_box: Box | None = None
        h, w = self.mask.shape
        q = 2 ** (levels - 1)
        x, y, bw, bh = _extent(self.mask)
        tx0, ty0, tx1, ty1 = _aligned_box(x - 2, y - 2, x + bw + 2, y + bh + 2, q, w, h)
        box = (x - search, y - search, x + bw + search, y + bh + search)
        ix0, iy0, ix1, iy1 = _aligned_box(*box, q, w, h)
        self._input_box = (ix0, iy0, ix1, iy1)
        gray = _gray(self.reference)
        tmpl = gray[ty0:ty1, tx0:tx1]
        tmask = self.mask[ty0:ty1, tx0:tx1].astype(np.float32)
        iters = (*iterations, *(iterations[-1:] * levels))
        self._levels: list[_Level] = []
        for k in range(levels - 1, -1, -1):
            s = 0.5**k
            t, m = tmpl, tmask
            if k:
                t = cv2.resize(tmpl, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
                m = cv2.resize(tmask, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
            count = iters[levels - 1 - k]
            to_tmpl, to_input = _to_level(s, tx0, ty0), _to_level(s, ix0, iy0)
            self._levels.append(
                _Level(
                    scale=s,
                    template=np.ascontiguousarray(t),
                    mask=np.where(m > 0.5, 255, 0).astype(np.uint8),
                    ref_to_tmpl=to_tmpl,
                    tmpl_to_ref=np.linalg.inv(to_tmpl),
                    frame_to_input=to_input,
                    input_to_frame=np.linalg.inv(to_input),
                    input_size=((ix1 - ix0) // 2**k, (iy1 - iy0) // 2**k),
                    criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, count, epsilon),
                )
            )
        self._ref_pyramid = self._pyramid(gray)
        self._basis: ConformBasis | None = None

    @classmethod
    def from_reference(
        cls,
        reference: np.ndarray,
        *,
        sample: np.ndarray | None = None,
        face: np.ndarray | None = None,
        mouth_box: Box | None = None,
        region: Region = "central",
        **settings,
    ) -> Stabilizer:
        """A stabilizer for ``reference``, finding the face and the mouth itself.

        Parameters
        ----------
        reference : numpy.ndarray
            (H, W, 3) uint8 RGB reference frame (:func:`choose_reference`).
        sample : numpy.ndarray, optional
            (N, H, W, 3) frames of speech of the same person (the reference's
            clip, say) to find the mouth in: they are first registered on the
            whole face, then :func:`locate_mouth` runs on them. Needed unless
            ``mouth_box`` is given.
        face : numpy.ndarray, optional
            (H, W) bool; :func:`locate_face` of the reference by default.
        mouth_box : tuple of int, optional
            ``(x, y, w, h)`` in the reference.
        region : {"central", "face", "rigid"}
            What to register on (:func:`registration_mask`).
        **settings
            Keyword settings of :class:`Stabilizer`.

        Returns
        -------
        Stabilizer
            With ``face`` and ``mouth_box`` set.

        Raises
        ------
        MiketalkError
            If neither ``sample`` nor ``mouth_box`` is given, or as the
            functions it calls.
        """
        reference = _check_frame(reference, "Stabilizer.from_reference")
        face = locate_face(reference) if face is None else np.asarray(face, bool)
        if mouth_box is None:
            if sample is None:
                raise MiketalkError("give mouth_box, or sample frames of speech to find it in")
            rough = cls(reference, face, **{**settings, "conform_degree": 0})
            transforms = rough.register(sample, clip="the sample", on_failure="nan")
            ok = np.isfinite(transforms[:, 0, 0])
            mouth_box = locate_mouth(rough.apply(sample[ok], transforms[ok]), face)
        mask = registration_mask(face, mouth_box, region=region)
        if (
            "conform_mask" not in settings
        ):  # the mouth between the cheeks: interpolated, not extrapolated
            top, _ = _eye_rows(mouth_box)
            settings["conform_mask"] = registration_mask(face, mouth_box, region="face")
            settings["conform_mask"][:top] = False
        out = cls(reference, mask, **settings)
        out.face = face
        out.mouth_box = tuple(int(v) for v in mouth_box)  # type: ignore[assignment]
        return out

    # -- per frame --

    def _pyramid(self, gray: np.ndarray) -> list[np.ndarray]:
        ix0, iy0, ix1, iy1 = self._input_box
        crop = np.ascontiguousarray(gray[iy0:iy1, ix0:ix1])
        return [
            crop
            if level.scale == 1
            else cv2.resize(crop, level.input_size, interpolation=cv2.INTER_AREA)
            for level in self._levels
        ]

    def _phase_start(self, pyramid: list[np.ndarray]) -> np.ndarray:
        """A translation found by phase correlation at the coarsest level."""
        level = self._levels[0]
        ref, img = self._ref_pyramid[0], pyramid[0]
        window = cv2.createHanningWindow((ref.shape[1], ref.shape[0]), cv2.CV_32F)
        (dx, dy), _ = cv2.phaseCorrelate(ref - ref.mean(), img - img.mean(), window)
        out = np.eye(3)
        out[:2, 2] = dx / level.scale, dy / level.scale
        return out

    def _register_one(
        self, pyramid: list[np.ndarray], warp: np.ndarray
    ) -> tuple[float, np.ndarray]:
        rho = 0.0
        for level, image in zip(self._levels, pyramid, strict=True):
            w32 = (level.frame_to_input @ warp @ level.tmpl_to_ref)[:2].astype(np.float32)
            rho, w32 = _ecc(level, level.mask, image, w32, self.blur)
            warp = level.input_to_frame @ _hom(w32) @ level.ref_to_tmpl
        if self.outlier_factor > 0:
            rho, warp = self._reweighted(pyramid[-1], warp, rho)
        return float(rho), warp

    def _reweighted(
        self, image: np.ndarray, warp: np.ndarray, rho: float
    ) -> tuple[float, np.ndarray]:
        """Register again at full size without the pixels that do not match (a blink, say)."""
        level = self._levels[-1]
        w32 = (level.frame_to_input @ warp @ level.tmpl_to_ref)[:2].astype(np.float32)
        t = level.template
        size = (t.shape[1], t.shape[0])
        warped = cv2.warpAffine(image, w32, size, flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
        inside = level.mask > 0
        a, b = t[inside], warped[inside]
        err = np.zeros(t.shape, np.float32)
        err[inside] = np.abs((a - a.mean()) / (a.std() + 1e-6) - (b - b.mean()) / (b.std() + 1e-6))
        err = cv2.GaussianBlur(err, (0, 0), 2.0)
        bad = inside & (err > self.outlier_factor * float(np.median(err[inside])))
        if not bad.any():
            return rho, warp
        bad = cv2.dilate(bad.astype(np.uint8), _disk(5)) > 0
        keep = np.where(inside & ~bad, 255, 0).astype(np.uint8)
        if (keep > 0).sum() < 0.5 * inside.sum():
            return rho, warp
        rho, w32 = _ecc(level, keep, image, w32, self.blur)
        return float(rho), level.input_to_frame @ _hom(w32) @ level.ref_to_tmpl

    def register(
        self,
        frames: np.ndarray,
        *,
        clip: str = "clip",
        init: np.ndarray | None = None,
        on_failure: Literal["raise", "nan"] = "raise",
    ) -> np.ndarray:
        """Affine transforms registering each frame to the reference.

        Parameters
        ----------
        frames : numpy.ndarray
            (N, H, W, 3) uint8 RGB (or (N, H, W)), the reference's size.
        clip : str
            Name used in error messages.
        init : numpy.ndarray, optional
            (2, 3) start for the first frame (default: phase correlation).
        on_failure : {"raise", "nan"}
            A frame that does not register raises, or gets a NaN transform
            (and the next frame starts afresh).

        Returns
        -------
        numpy.ndarray
            (N, 2, 3) float64 ``T``: reference pixel ``(x, y)`` shows in the
            frame at ``T @ (x, y, 1)``. :attr:`correlations` holds each
            frame's ECC correlation.

        Raises
        ------
        MiketalkError
            Naming the clip and frame, if ECC does not converge or the
            correlation is below ``min_correlation`` (``on_failure="raise"``).
        """
        frames = np.asarray(frames)
        if frames.ndim not in (3, 4) or frames.shape[1:3] != self.mask.shape:
            raise MiketalkError(
                f"{clip}: frames of shape {frames.shape[1:3]} do not match the reference's "
                f"{self.mask.shape}"
            )
        n = frames.shape[0]
        out = np.empty((n, 2, 3))
        self.correlations = np.full(n, np.nan)
        warp = None if init is None else _hom(init)
        for i in range(n):
            pyramid = self._pyramid(_gray(frames[i]))
            rho, found = NOT_CONVERGED, None
            for start in (warp, None) if warp is not None else (None,):
                try:
                    rho, found = self._register_one(
                        pyramid, self._phase_start(pyramid) if start is None else start
                    )
                except cv2.error:
                    rho, found = NOT_CONVERGED, None
                if rho >= self.min_correlation:
                    break
            self.correlations[i] = rho
            if found is None or rho < self.min_correlation:
                if on_failure == "nan":
                    out[i], warp = np.nan, None
                    continue
                raise MiketalkError(self.failure(i, clip=clip))
            warp = found
            out[i] = warp[:2]
        return out

    def failure(self, i: int, *, clip: str = "clip") -> str:
        """Why frame ``i`` of the last :meth:`register` did not register, in one line."""
        rho = float(self.correlations[i])
        why = "ECC did not converge" if rho == NOT_CONVERGED else f"correlation {rho:.3f}"
        return (
            f"{clip} frame {i} does not register to the reference: {why} "
            f"(at least {self.min_correlation} needed)"
        )

    # -- per clip --

    def conform(
        self, frames: np.ndarray, transforms: np.ndarray, *, clip: str = "clip"
    ) -> np.ndarray | None:
        """The clip's smooth field carrying the reference's face onto the clip's.

        Parameters
        ----------
        frames : numpy.ndarray
            (N, H, W, 3) the clip's frames.
        transforms : numpy.ndarray
            (N, 2, 3) from :meth:`register` (NaN rows are left out).
        clip : str
            Name used in error messages.

        Returns
        -------
        numpy.ndarray or None
            (H, W, 2) float32 offsets ``F``: reference pixel ``p`` is taken
            from the affinely stabilized clip at ``p + F(p)``. None if
            ``conform_degree`` is 0.

        Raises
        ------
        MiketalkError
            If no frame registered, or the field exceeds ``max_conform`` face
            widths on the mask.
        """
        if self.conform_degree <= 0:
            return None
        ok = np.isfinite(transforms[:, 0, 0])
        if not ok.any():
            raise MiketalkError(f"{clip}: no frame registered, nothing to conform")
        if self._basis is None:
            self._basis = ConformBasis.over(self.conform_mask, degree=self.conform_degree)
        steady = self.apply(frames[ok], transforms[ok])[:, self._basis.rows, self._basis.cols]
        return self._basis.fit(self.reference, steady, max_conform=self.max_conform, clip=clip)

    def apply(
        self, frames: np.ndarray, transforms: np.ndarray, *, field: np.ndarray | None = None
    ) -> np.ndarray:
        """Warp frames onto the reference (:func:`~miketalk.stabilize.warp_to_reference`).

        ``transforms`` come from :meth:`register`, ``field`` from :meth:`conform`;
        interpolation is this stabilizer's.
        """
        return warp_to_reference(frames, transforms, field=field, interpolation=self.interpolation)

    def stabilize(self, frames: np.ndarray, *, clip: str = "clip") -> Stabilized:
        """Register, conform and warp one clip (:meth:`register`, :meth:`conform`, :meth:`apply`).

        Raises
        ------
        MiketalkError
            If a frame does not register, or the clip does not conform.
        """
        transforms = self.register(frames, clip=clip)
        return self.registered(frames, transforms, self.correlations.copy(), clip=clip)

    def registered(
        self,
        frames: np.ndarray,
        transforms: np.ndarray,
        correlations: np.ndarray,
        *,
        clip: str = "clip",
    ) -> Stabilized:
        """Conform and warp a clip :meth:`register` has registered (:meth:`conform`,
        :meth:`apply`); ``correlations`` are its frames' (:attr:`correlations`)."""
        field = self.conform(frames, transforms, clip=clip)
        return Stabilized(
            self.apply(frames, transforms, field=field), transforms, field, correlations
        )
