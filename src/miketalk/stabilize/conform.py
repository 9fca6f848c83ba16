"""The conform field: one smooth field per clip carrying the reference's face onto the clip's.

An affine transform does not bring another recording session's face onto the
reference: the head's pitch and yaw differ by a few degrees and the face is not
flat. The field is the dense flow (DIS, preset medium) from the reference to the
clip's median affinely stabilized frame, fitted by a bivariate polynomial of
degree ``d`` over the conform mask (the face below the brows outside the mouth
zone, so that the mouth's field is interpolated, not extrapolated) and faded out
beyond the face.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.stabilize.locate import _extent, _gray_stack, _u8gray


@dataclass(frozen=True)
class ConformBasis:
    """The polynomial basis over the frame, its pseudo-inverse on the mask, and the fade.

    Attributes
    ----------
    mask : numpy.ndarray
        (H, W) bool, where the field is fitted.
    basis : numpy.ndarray
        (H * W, K) monomials ``u**i * v**j``, ``i + j <= d``, of the frame's
        coordinates centred on the mask's box and scaled by half its larger side.
    pinv : numpy.ndarray
        (K, M) float32 pseudo-inverse of the basis on the mask's ``M`` pixels.
    fade : numpy.ndarray
        (H, W) float32, 1 over the mask's box grown by a quarter of its size,
        blurred to 0 beyond.
    rows, cols : slice
        The crop (the mask's box grown by a tenth) where the flow is measured.
    """

    mask: np.ndarray
    basis: np.ndarray
    pinv: np.ndarray
    fade: np.ndarray
    rows: slice
    cols: slice

    @classmethod
    def over(cls, mask: np.ndarray, *, degree: int) -> ConformBasis:
        """The basis of degree ``degree`` for fields fitted on ``mask``."""
        h, w = mask.shape
        x, y, bw, bh = _extent(mask)
        scale = max(bw, bh) / 2
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        u, v = (xx - (x + bw / 2)) / scale, (yy - (y + bh / 2)) / scale
        basis = np.stack(
            [(u**i * v**j).ravel() for i in range(degree + 1) for j in range(degree + 1 - i)],
            axis=1,
        )
        pinv = np.linalg.pinv(basis[mask.ravel()].astype(np.float64))
        fade = np.zeros((h, w), np.float32)
        grow = round(0.25 * max(bw, bh))
        fade[max(0, y - grow) : y + bh + grow, max(0, x - grow) : x + bw + grow] = 1
        fade = cv2.GaussianBlur(fade, (0, 0), grow / 2)
        pad = round(0.1 * max(bw, bh))
        rows = slice(max(0, y - pad), y + bh + pad)
        cols = slice(max(0, x - pad), x + bw + pad)
        return cls(mask, basis, pinv.astype(np.float32), fade, rows, cols)

    def fit(
        self, reference: np.ndarray, steady: np.ndarray, *, max_conform: float, clip: str
    ) -> np.ndarray:
        """The field from ``reference`` to the median of a clip's affinely stabilized crops.

        Parameters
        ----------
        reference : numpy.ndarray
            (H, W, 3) or (H, W) uint8 reference frame.
        steady : numpy.ndarray
            (N, h, w[, 3]) the clip's registered frames cropped to ``rows, cols``.
        max_conform : float
            Largest offset allowed, in widths of the mask's box.
        clip : str
            Name used in error messages.

        Returns
        -------
        numpy.ndarray
            (H, W, 2) float32 offsets ``F``: reference pixel ``p`` is taken from the
            affinely stabilized clip at ``p + F(p)``.

        Raises
        ------
        MiketalkError
            If the field exceeds ``max_conform`` widths on the mask: the clip does
            not show the reference's face.
        """
        median = np.median(_gray_stack(steady), axis=0)
        ref_crop = np.ascontiguousarray(_u8gray(reference)[self.rows, self.cols])
        dis = cv2.DISOpticalFlow_create(cv2.DISOpticalFlow_PRESET_MEDIUM)
        flow = np.zeros((*self.mask.shape, 2), np.float32)
        flow[self.rows, self.cols] = dis.calc(
            ref_crop, np.clip(median + 0.5, 0, 255).astype(np.uint8), None
        )
        coef = self.pinv @ flow.reshape(-1, 2)[self.mask.ravel()]
        field = (self.basis @ coef).reshape(*self.mask.shape, 2) * self.fade[..., None]
        largest = float(np.sqrt((field[self.mask] ** 2).sum(axis=1)).max())
        width = _extent(self.mask)[2]
        if largest > max_conform * width:
            raise MiketalkError(
                f"{clip} does not register to the reference: its face differs by {largest:.1f} "
                f"px after the affine registration (at most {max_conform * width:.1f})"
            )
        return field.astype(np.float32)
