"""In-between frames of real video: predict frame ``t + k/2`` from frames ``t`` and ``t + k``.

A model-free test of the morph on a real face. For real frames ``t`` and
``t + k`` of a clip, each :class:`Method` predicts the frame half-way between
them, and the prediction is compared with the real frame ``t + k/2`` on the
mouth region (:func:`miketalk_lab.evaluation.measures.psnr` and ``ssim`` over the
mouth box). The methods:

``dissolve``
    the cross-dissolve ``0.5 * I_t + 0.5 * I_{t+k}`` (no motion at all);
``morph/<estimator>``
    the paper's morph (:class:`miketalk.render.morph.Morpher`, ``alpha = 0.5``, its
    default stages: rounded forward warps, hole-aware blend, hole fill, 3x3
    median) with flows both ways from the estimator;
``morph-nomedian/<estimator>``
    the same without the median;
``morph-bilinear/<estimator>``
    the morph with bilinear splatting and no median
    (``Morpher(..., splat="bilinear", median=False)``);
``slomo/<estimator>``
    backward warping in the manner of Super SloMo's linear approximation of
    the intermediate flow (Jiang et al. 2018, their Eq. 4), nothing learned:
    :func:`miketalk_lab.evaluation.slomo.slomo_frame`.

Flows are estimated once per pair and estimator and shared by every method
that uses them. They are estimated on a crop around the mouth box (the box
grown by ``context`` times its size on every side; ``context=None`` uses the
whole frame), where the morphs and warps are made too: the mouth box is far
from the crop's edges, and a 360x288 frame costs 3-4 times as much.

The mouth box can come from :func:`miketalk.mouth.lip_colour.find_mouth_box` (where the lips' colour
changes over the clip) or from anywhere else; the measures never see outside it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.flow.registry import Estimator, get_estimator
from miketalk.mouth.region import Box
from miketalk.render.morph import Morpher, cross_dissolve
from miketalk_lab.evaluation.measures import psnr, ssim
from miketalk_lab.evaluation.slomo import slomo_frame

__all__ = [
    "COLUMNS",
    "VARIANTS",
    "Method",
    "default_methods",
    "inbetween_table",
]


Kind = Literal["dissolve", "morph", "slomo"]


#: The columns of :func:`inbetween_table`, in order.
COLUMNS = ("clip", "t", "k", "method", "psnr_mouth", "ssim_mouth")


#: Morph variants by name: the keyword options given to :class:`miketalk.render.morph.Morpher`
#: (``slomo`` is not a morph; it is listed so that one name list selects every method).
VARIANTS: Mapping[str, Mapping[str, Any] | None] = MappingProxyType(
    {
        "morph": MappingProxyType({}),
        "morph-nomedian": MappingProxyType({"median": False}),
        "morph-bilinear": MappingProxyType({"splat": "bilinear", "median": False}),
        "morph-bilinear-median": MappingProxyType({"splat": "bilinear"}),
        "slomo": None,
    }
)


_DISSOLVE = "dissolve"


@dataclass(frozen=True)
class Method:
    """One way to predict the in-between frame.

    Attributes
    ----------
    name : str
        The name in the table (e.g. ``"morph/bergen"``).
    kind : {"dissolve", "morph", "slomo"}
        What is done with the two frames (module docstring).
    estimator : Estimator, optional
        The flow estimator (with its settings); None for ``dissolve``.
    options : mapping
        Keyword options of :class:`miketalk.render.morph.Morpher` (``morph`` only).
    """

    name: str
    kind: Kind
    estimator: Estimator | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in ("dissolve", "morph", "slomo"):
            raise MiketalkError(f"unknown method kind {self.kind!r}")
        if (self.kind == "dissolve") != (self.estimator is None):
            raise MiketalkError(f"method {self.name!r}: only a dissolve goes without a flow")
        if self.options and self.kind != "morph":
            raise MiketalkError(f"method {self.name!r}: morph options on a {self.kind}")
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    @property
    def flow_key(self) -> tuple[str, tuple[tuple[str, Any], ...]] | None:
        """What identifies this method's flows: the estimator and its settings."""
        if self.estimator is None:
            return None
        return self.estimator.name, tuple(sorted(self.estimator.settings.items()))


def default_methods(
    estimators: Iterable[str | Estimator | tuple[str, Estimator]] = (
        "bergen",
        "dis_medium",
        "farneback",
    ),
    *,
    variants: Iterable[str] = ("morph", "morph-nomedian", "morph-bilinear", "slomo"),
) -> list[Method]:
    """The dissolve, then every variant for every estimator.

    Parameters
    ----------
    estimators : iterable
        Registry names (default settings), :class:`~miketalk.flow.registry.Estimator`
        objects (named by their registry name), or ``(label, estimator)`` pairs
        naming an estimator with its own settings.
    variants : iterable of str, keyword-only
        Keys of :data:`VARIANTS`.

    Returns
    -------
    list of Method
        ``dissolve`` first, then ``<variant>/<label>`` by estimator.

    Raises
    ------
    MiketalkError
        For an unknown variant or estimator, or two estimators with one label.
    """
    variants = list(variants)
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise MiketalkError(f"unknown variant(s) {unknown}; known: {', '.join(VARIANTS)}")
    methods = [Method(_DISSOLVE, "dissolve")]
    labels: set[str] = set()
    for entry in estimators:
        if isinstance(entry, tuple):
            label, estimator = entry
        elif isinstance(entry, Estimator):
            label, estimator = entry.name, entry
        else:
            label, estimator = str(entry), get_estimator(str(entry))
        if label in labels:
            raise MiketalkError(f"two estimators are labelled {label!r}")
        labels.add(label)
        for variant in variants:
            options = VARIANTS[variant]
            if options is None:
                methods.append(Method(f"{variant}/{label}", "slomo", estimator))
            else:
                methods.append(Method(f"{variant}/{label}", "morph", estimator, options))
    return methods


def _check_box(box: Sequence[int], height: int, width: int) -> Box:
    if len(box) != 4:
        raise MiketalkError(f"mouth_box must be (x, y, w, h), got {box!r}")
    x, y, w, h = (int(v) for v in box)
    if w < 7 or h < 7 or x < 0 or y < 0 or x + w > width or y + h > height:
        raise MiketalkError(
            f"mouth_box {box!r} must lie inside the {width}x{height} frame and be at least "
            "7x7 (the SSIM window)"
        )
    return x, y, w, h


def _crop_of(box: Box, height: int, width: int, context: float | None) -> Box:
    """The box grown by ``context`` times its size on every side, clipped to the frame."""
    if context is None:
        return 0, 0, width, height
    x, y, w, h = box
    mx, my = math.ceil(context * w), math.ceil(context * h)
    x0, y0 = max(0, x - mx), max(0, y - my)
    return x0, y0, min(width, x + w + mx) - x0, min(height, y + h + my) - y0


def _predict(
    method: Method, image0: np.ndarray, image1: np.ndarray, flows: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    if method.kind == "dissolve":
        return cross_dissolve(image0, image1, 0.5)
    if method.kind == "slomo":
        return slomo_frame(image0, image1, *flows, 0.5)
    return Morpher(image0, image1, *flows, **method.options).frame(0.5)


def _check_ks(ks: Iterable[int]) -> list[int]:
    out = []
    for k in ks:
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 2 or k % 2:
            raise MiketalkError(f"every k must be an even integer >= 2, got {k!r}")
        out.append(int(k))
    if not out:
        raise MiketalkError("ks is empty")
    return out


def inbetween_table(
    frames: np.ndarray,
    *,
    mouth_box: Sequence[int],
    ks: Iterable[int] = (2, 4, 8),
    methods: Sequence[Method] | None = None,
    step: int = 2,
    context: float | None = 1.0,
    clip: str = "clip",
) -> pd.DataFrame:
    """Predict frame ``t + k/2`` from frames ``t`` and ``t + k`` by each method; measure it.

    Parameters
    ----------
    frames : ndarray, shape (N, H, W, 3) or (N, H, W), uint8
        The clip's frames, in order, evenly spaced in time.
    mouth_box : (x, y, w, h), keyword-only
        The region measured (at least 7x7, inside the frame).
    ks : iterable of int, keyword-only
        Gaps between the two known frames; even, so that ``t + k/2`` is a frame.
    methods : sequence of Method, keyword-only
        Default: :func:`default_methods` with its defaults. Methods sharing an estimator
        (and its settings) share its flows.
    step : int, keyword-only
        Every ``step``-th ``t`` from 0 while ``t + k`` is a frame.
    context : float or None, keyword-only
        Flows, morphs and warps are made on the mouth box grown by ``context``
        times its width and height on each side (clipped to the frame); None
        uses the whole frame.
    clip : str, keyword-only
        The clip's name in the table.

    Returns
    -------
    pandas.DataFrame
        One row per (t, k, method), columns :data:`COLUMNS`: ``clip``, ``t``,
        ``k``, ``method``, ``psnr_mouth`` (dB; ``inf`` for an exact match) and
        ``ssim_mouth``.

    Raises
    ------
    MiketalkError
        For malformed frames, box, ``ks``, ``step`` or ``context``, or a clip
        shorter than ``k + 1`` frames for every ``k``.
    """
    frames = np.asarray(frames)
    if frames.ndim not in (3, 4) or frames.dtype != np.uint8:
        raise MiketalkError(
            f"frames must be (N, H, W[, 3]) uint8, got {frames.shape} {frames.dtype}"
        )
    n, height, width = frames.shape[:3]
    box = _check_box(mouth_box, height, width)
    ks = _check_ks(ks)
    if isinstance(step, bool) or not isinstance(step, int | np.integer) or step < 1:
        raise MiketalkError(f"step must be an integer >= 1, got {step!r}")
    if context is not None and not (isinstance(context, int | float) and context >= 0):
        raise MiketalkError(f"context must be None or a number >= 0, got {context!r}")
    if n <= min(ks):
        raise MiketalkError(f"clip {clip!r} has {n} frames: too short for k = {min(ks)}")
    methods = list(default_methods() if methods is None else methods)
    if not methods:
        raise MiketalkError("no methods")
    names = [m.name for m in methods]
    if len(set(names)) != len(names):
        raise MiketalkError(f"method names repeat: {names}")
    cx, cy, cw, ch = _crop_of(box, height, width, context)
    crop = frames[:, cy : cy + ch, cx : cx + cw]
    mask = np.zeros((ch, cw), bool)
    mask[box[1] - cy : box[1] - cy + box[3], box[0] - cx : box[0] - cx + box[2]] = True
    estimators: dict[Any, Estimator] = {}
    for method in methods:
        if method.flow_key is not None:
            estimators.setdefault(method.flow_key, method.estimator)
    rows: list[tuple[Any, ...]] = []
    for k in ks:
        for t in range(0, n - k, step):
            image0, image1, truth = crop[t], crop[t + k], crop[t + k // 2]
            flows = {key: (e(image0, image1), e(image1, image0)) for key, e in estimators.items()}
            for method in methods:
                pair = flows.get(method.flow_key, ())
                predicted = _predict(method, image0, image1, pair)
                rows.append(
                    (
                        clip,
                        t,
                        k,
                        method.name,
                        psnr(predicted, truth, mask),
                        ssim(predicted, truth, mask),
                    )
                )
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    return table.astype({"t": np.int64, "k": np.int64})
