"""A morph between more than two visemes (beyond the paper), the paper's morph as its special case.

The learned coarticulation (:mod:`miketalk.draw.coarticulation`) puts the mouth
at points between several visemes: weights ``w_V`` summing to 1. A frame is
drawn from them as follows (:meth:`MultiMorpher.frame`):

one viseme
    its image;
two visemes ``A`` then ``B``
    the paper's two-image morph (:class:`miketalk.render.morph.Morpher`, through
    the source's ``frame``, e.g. :meth:`miketalk.model.face.Model.frame`) at
    ``alpha = w_B / (w_A + w_B)``,
    byte for byte what the paper's renderer draws at that alpha;
three or more
    the viseme of the largest weight is the reference ``R``. Each other viseme
    ``V_j`` is brought into ``R``'s geometry by backward-warping it along the
    flow ``F_j = flow(R -> V_j)`` (:func:`miketalk.flow.warp.backward_warp`:
    ``R(p) ~ V_j(p + F_j(p))``); the appearance is the weighted blend
    ``A = w_R R + sum_j w_j V_j(p + F_j(p))`` in ``R``'s geometry, and the
    blended shape moves pixel ``p`` of ``R`` to ``p + S(p)``,
    ``S = sum_j w_j F_j``. The frame is ``A`` moved to that shape by a
    backward warp: ``out(q) = A(P(q))`` with ``P`` the inverse of
    ``p -> p + S(p)``, found by the fixed-point iteration ``P <- q - S(P)``
    (``inverse_iterations`` steps; 0 is the first-order ``P = q - S(q)``).
    With two visemes this path is the two-image morph made by backward warps
    (no holes to fill); it is measured against the paper's forward-warp morph
    in ``tests/product/test_coarticulation.py``. The model's ``median`` setting applies
    as in the paper's morph (3x3 median).

All warps are ``cv2.remap`` in float32. :func:`miketalk.draw.learned.render_learned`
draws a timeline with the learned weights.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Protocol

import cv2
import numpy as np

from miketalk.errors import MiketalkError

__all__ = ["MorphSource", "MultiMorpher", "Weights"]


class MorphSource(Protocol):
    """What the N-way morph needs of a model: images, flows and the two-image morph."""

    size: tuple[int, int]
    morph_options: Mapping[str, object]

    def image(self, viseme: str) -> np.ndarray:
        """The viseme's image, (H, W, 3) uint8."""
        ...

    def frame(self, a: str, b: str, alpha: float) -> np.ndarray:
        """The paper's morph from ``a`` to ``b`` at ``alpha``."""
        ...

    def flow_pair(self, a: str, b: str) -> tuple[np.ndarray, np.ndarray]:
        """Flows ``a -> b`` and ``b -> a``, (H, W, 2) float32."""
        ...


#: Weights (viseme, weight) of one frame.
Weights = Sequence[tuple[str, float]]

#: A region of a frame, ``(x0, y0, x1, y1)``.
Box = tuple[int, int, int, int]


class MultiMorpher:
    """Frames at any weighted point between a model's visemes (see the module docstring).

    Parameters
    ----------
    model : MorphSource
        The visemes' images, flows and morph settings (a
        :class:`miketalk.model.face.Model`).
    inverse_iterations : int
        Fixed-point steps inverting the blended shape (0: first order).
    flow_cache : int
        Flow fields kept in memory (each ``H x W x 2`` float32).

    Notes
    -----
    Thread-safe: the flows are read through the model's reading thread and
    shared read-only; the work of a frame uses no shared buffer.
    """

    def __init__(
        self, model: MorphSource, *, inverse_iterations: int = 2, flow_cache: int = 48
    ) -> None:
        if inverse_iterations < 0:
            raise MiketalkError(f"inverse_iterations must be >= 0, not {inverse_iterations}")
        self.model = model
        self.inverse_iterations = int(inverse_iterations)
        self.median = bool(model.morph_options.get("median", True))
        h, w = model.size
        xs, ys = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
        self._grid = np.ascontiguousarray(np.stack([xs, ys], axis=-1))
        self._flows: OrderedDict[tuple[str, str], np.ndarray] = OrderedDict()
        self._cache_size = max(2, int(flow_cache))
        self._lock = threading.Lock()

    def flow(self, a: str, b: str) -> np.ndarray:
        """The flow ``a -> b`` (``a(p) ~ b(p + flow(p))``), float32, read once and cached."""
        key = (a, b)
        with self._lock:
            if key in self._flows:
                self._flows.move_to_end(key)
                return self._flows[key]
        forward, backward = self.model.flow_pair(a, b)
        with self._lock:
            self._flows[(a, b)] = forward
            self._flows[(b, a)] = backward
            while len(self._flows) > self._cache_size:
                self._flows.popitem(last=False)
        return forward

    def frame(self, weights: Weights, *, region: Box | None = None) -> np.ndarray:
        """The frame at the weighted point ``weights`` (``(viseme, weight)``, weights >= 0).

        Visemes of zero weight are ignored; the others are renormalized. Two
        visemes are the paper's morph from the first to the second. With ``region``
        ``(x0, y0, x1, y1)``, three or more are drawn there only (:meth:`blend`).

        Raises
        ------
        MiketalkError
            For no positive weight, a negative or non-finite weight, a viseme
            named twice or unknown to the model.
        """
        items = [(str(v), float(w)) for v, w in weights]
        if any(not np.isfinite(w) or w < 0 for _, w in items):
            raise MiketalkError(f"weights must be finite and >= 0, got {items}")
        items = [(v, w) for v, w in items if w > 0]
        names = [v for v, _ in items]
        if len(set(names)) != len(names):
            raise MiketalkError(f"a viseme is named twice in {items}")
        if not items:
            raise MiketalkError("no viseme has a positive weight")
        if len(items) == 1:
            return self.model.image(items[0][0])
        if len(items) == 2:
            (a, wa), (b, wb) = items
            return self.model.frame(a, b, wb / (wa + wb))
        return self.blend(items, region=region)

    def blend(self, weights: Weights, *, region: Box | None = None) -> np.ndarray:
        """The backward-warp blend of the module docstring, for any number of visemes.

        With ``region`` ``(x0, y0, x1, y1)`` only its pixels are drawn, byte for byte
        what the whole frame has there (each output pixel's arithmetic is its own; the
        appearance is made only where the region samples it, the median filter's one
        pixel beyond it included); the rest of the frame is the reference viseme's image
        (a frame composited into video is read only in the mouth's region,
        :meth:`miketalk.composite.compositor.Compositor.render_region`).
        """
        total = sum(w for _, w in weights)
        items = [(v, w / total) for v, w in weights]
        reference, w_ref = max(items, key=lambda item: item[1])
        image = self.model.image(reference)
        h, w = self.model.size
        x0, y0, x1, y1 = (0, 0, w, h) if region is None else region
        if self.median:  # the 3x3 median's pixel beyond the region
            x0, y0, x1, y1 = max(0, x0 - 1), max(0, y0 - 1), min(w, x1 + 1), min(h, y1 + 1)
        others = [(self.flow(reference, v), v, wv) for v, wv in items if v != reference]
        shape = np.zeros((h, w, 2), np.float32)
        for flow, _, wv in others:
            cv2.scaleAdd(flow, float(wv), shape, dst=shape)
        # P(q) = q - S(P(q)): start at q - S(q), iterate (on the region's pixels q)
        grid = self._grid[y0:y1, x0:x1]
        where = grid - shape[y0:y1, x0:x1]
        for _ in range(self.inverse_iterations):
            where = grid - _remap(shape, where)
        # the appearance where ``where`` samples it (bilinear: the pixel after it too)
        ax0, ay0 = (
            max(0, min(w - 1, int(np.floor(v.min())))) for v in (where[..., 0], where[..., 1])
        )
        ax1, ay1 = (
            max(1, min(n, int(np.floor(v.max())) + 2))
            for v, n in ((where[..., 0], w), (where[..., 1], h))
        )
        ax1, ay1 = max(ax1, ax0 + 1), max(ay1, ay0 + 1)
        appearance = image[ay0:ay1, ax0:ax1].astype(np.float32) * np.float32(w_ref)
        for flow, viseme, wv in others:
            sampled = self._grid[ay0:ay1, ax0:ax1] + flow[ay0:ay1, ax0:ax1]
            warped = _remap(self.model.image(viseme), sampled)
            cv2.scaleAdd(warped.astype(np.float32), float(wv), appearance, dst=appearance)
        offset = np.array([ax0, ay0], np.float32)
        out = _remap(appearance, where - offset)
        out = np.clip(np.floor(out + 0.5), 0, 255).astype(np.uint8)
        out = cv2.medianBlur(out, 3) if self.median else out
        if region is None:
            return out
        frame = np.array(image, np.uint8, copy=True)
        rx0, ry0, rx1, ry1 = region
        frame[ry0:ry1, rx0:rx1] = out[ry0 - y0 : ry1 - y0, rx0 - x0 : rx1 - x0]
        return frame


def _remap(image: np.ndarray, where: np.ndarray) -> np.ndarray:
    """Bilinear ``image(where(q))`` with replicated borders (``where`` absolute, float32)."""
    out = cv2.remap(image, where, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(where.shape[:2] + image.shape[2:])
