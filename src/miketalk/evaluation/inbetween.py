"""In-between frames of real video: predict frame ``t + k/2`` from frames ``t`` and ``t + k``.

A model-free test of the morph on a real face. For real frames ``t`` and
``t + k`` of a clip, each :class:`Method` predicts the frame half-way between
them, and the prediction is compared with the real frame ``t + k/2`` on the
mouth region (:func:`miketalk.evaluation.measures.psnr` and ``ssim`` over the
mouth box). The methods:

``dissolve``
    the cross-dissolve ``0.5 * I_t + 0.5 * I_{t+k}`` (no motion at all);
``morph/<estimator>``
    the paper's morph (:class:`miketalk.morph.Morpher`, ``alpha = 0.5``, its
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
    :func:`slomo_frame`.

Flows are estimated once per pair and estimator and shared by every method
that uses them. They are estimated on a crop around the mouth box (the box
grown by ``context`` times its size on every side; ``context=None`` uses the
whole frame), where the morphs and warps are made too: the mouth box is far
from the crop's edges, and a 360x288 frame costs 3-4 times as much.

The mouth box can come from :func:`find_mouth_box` (where the lips' colour
changes over the clip) or from anywhere else; the measures never see outside it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal

import cv2
import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.evaluation.measures import psnr, ssim
from miketalk.flow.registry import Estimator, get_estimator
from miketalk.flow.warp import backward_warp
from miketalk.render.morph import Morpher, cross_dissolve

__all__ = [
    "COLUMNS",
    "VARIANTS",
    "Box",
    "Method",
    "default_methods",
    "find_mouth_box",
    "inbetween_table",
    "slomo_flows",
    "slomo_frame",
    "summarize_inbetween",
    "summary_markdown",
]

Box = tuple[int, int, int, int]
Kind = Literal["dissolve", "morph", "slomo"]

#: The columns of :func:`inbetween_table`, in order.
COLUMNS = ("clip", "t", "k", "method", "psnr_mouth", "ssim_mouth")

#: Morph variants by name: the keyword options given to :class:`miketalk.morph.Morpher`
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


# ---------------------------------------------------------------------------
# methods
# ---------------------------------------------------------------------------


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
        Keyword options of :class:`miketalk.morph.Morpher` (``morph`` only).
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


# ---------------------------------------------------------------------------
# Super SloMo's linear approximation
# ---------------------------------------------------------------------------


def slomo_flows(
    flow01: np.ndarray, flow10: np.ndarray, tau: float
) -> tuple[np.ndarray, np.ndarray]:
    """The intermediate flows of Super SloMo's linear approximation (Jiang et al. 2018, Eq. 4).

    ``F_t0 = -(1 - tau) tau F_01 + tau^2 F_10`` and
    ``F_t1 = (1 - tau)^2 F_01 - tau (1 - tau) F_10``: the flows from the
    frame at time ``tau`` back to frames 0 and 1, on the in-between frame's
    grid, assuming each pixel moves on a straight line at constant speed.

    Parameters
    ----------
    flow01, flow10 : ndarray, shape (H, W, 2)
        Flows from frame 0 to frame 1 and from frame 1 to frame 0 (our
        convention: ``I0(p) ~ I1(p + flow01(p))``).
    tau : float
        The in-between time in ``[0, 1]``.

    Returns
    -------
    flow_t0, flow_t1 : ndarray, shape (H, W, 2), float32
        ``I_tau(p) ~ I0(p + flow_t0(p)) ~ I1(p + flow_t1(p))``.

    Examples
    --------
    >>> import numpy as np
    >>> f01 = np.full((2, 2, 2), 4.0, np.float32)
    >>> f_t0, f_t1 = slomo_flows(f01, -f01, 0.25)
    >>> float(f_t0[0, 0, 0]), float(f_t1[0, 0, 0])
    (-1.0, 3.0)
    """
    tau = _check_tau(tau)
    f01 = np.asarray(flow01, np.float32)
    f10 = np.asarray(flow10, np.float32)
    if f01.shape != f10.shape or f01.ndim != 3 or f01.shape[2] != 2:
        raise MiketalkError(f"flows must both be (H, W, 2), got {f01.shape} and {f10.shape}")
    a, b = np.float32(tau), np.float32(1.0 - tau)
    flow_t0 = -(b * a) * f01 + (a * a) * f10
    flow_t1 = (b * b) * f01 - (a * b) * f10
    return flow_t0, flow_t1


def slomo_frame(
    image0: np.ndarray, image1: np.ndarray, flow01: np.ndarray, flow10: np.ndarray, tau: float
) -> np.ndarray:
    """The in-between frame at ``tau`` by backward warps along :func:`slomo_flows`.

    Both frames are warped backwards (bilinear,
    :func:`miketalk.flow.warp.backward_warp`) to time ``tau`` and blended with
    weights ``1 - tau`` and ``tau``: Super SloMo's Eq. 1 without its learned
    refinement and visibility maps.

    Parameters
    ----------
    image0, image1 : ndarray, shape (H, W) or (H, W, 3), uint8
        Frames 0 and 1.
    flow01, flow10 : ndarray, shape (H, W, 2)
        Flows between them, both ways.
    tau : float
        The in-between time in ``[0, 1]``.

    Returns
    -------
    ndarray
        uint8, the shape of ``image0`` (rounded half up).
    """
    if image0.shape != image1.shape:
        raise MiketalkError(f"image shapes differ: {image0.shape} vs {image1.shape}")
    flow_t0, flow_t1 = slomo_flows(flow01, flow10, tau)
    warp0 = backward_warp(image0, flow_t0).astype(np.float32)
    warp1 = backward_warp(image1, flow_t1).astype(np.float32)
    mixed = np.float32(1.0 - tau) * warp0 + np.float32(tau) * warp1
    return np.clip(np.floor(mixed + np.float32(0.5)), 0, 255).astype(np.uint8)


def _check_tau(tau: object) -> float:
    if isinstance(tau, bool) or not isinstance(tau, int | float | np.floating | np.integer):
        raise MiketalkError(f"tau must be a number in [0, 1], got {tau!r}")
    value = float(tau)
    if not 0.0 <= value <= 1.0:
        raise MiketalkError(f"tau must be in [0, 1], got {value}")
    return value


# ---------------------------------------------------------------------------
# the mouth box
# ---------------------------------------------------------------------------


def find_mouth_box(
    frames: np.ndarray,
    *,
    head: np.ndarray | None = None,
    size: tuple[float, float] = (0.45, 0.30),
    step: int = 2,
) -> Box:
    """The mouth box of a frontal talking head, from where the lips' redness changes.

    Lips are redder than skin and the mouth's inside is not, so while a person
    speaks the CIELAB ``a*`` (green-red) channel changes most at the lips. Per
    pixel, the 75th percentile over the clip of ``|a* - median a*|`` is taken
    (blinks, a few frames, do not reach it) and smoothed; its peak is searched
    in the middle 40 % of the head's width, between 0.85 and 1.4 head widths
    below the top of the head (the mouth of an upright frontal head is about
    1.1 head widths below its top, the eyes about 0.6). The box is centred
    across on the weighted centre of the change around the peak, and up and
    down on the lips (the redness of the median frame there), so that it holds
    both lips even when the lower lip's edge moves most.

    Parameters
    ----------
    frames : ndarray, shape (N, H, W, 3), uint8 RGB
        The clip (at least 3 frames).
    head : ndarray of bool, shape (H, W), optional, keyword-only
        The head (hair and ears included) against the background; by default
        :func:`miketalk.corpus.stabilize.locate_head` of the clip's median frame.
    size : (float, float), keyword-only
        The box's width and height as fractions of the head's width (for
        GRID's 360x288 frames the head is about 150 px wide: a 68x45 box).
    step : int, keyword-only
        Use every ``step``-th frame.

    Returns
    -------
    (x, y, w, h) : tuple of int
        Inside the frame.

    Raises
    ------
    MiketalkError
        For frames that are not an RGB clip, when no head is found, or when the
        head is too close to the frame's bottom edge.
    """
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        raise MiketalkError(f"frames must be (N, H, W, 3) uint8, got {frames.shape} {frames.dtype}")
    if frames.shape[0] < 3:
        raise MiketalkError(f"find_mouth_box needs at least 3 frames, got {frames.shape[0]}")
    sample = frames[:: max(1, int(step))]
    height, width = frames.shape[1:3]
    if head is None:
        from miketalk.stabilize import locate_head

        head = locate_head(np.median(sample, axis=0).astype(np.uint8))
    head = np.asarray(head, bool)
    if head.shape != (height, width) or not head.any():
        raise MiketalkError(f"the head mask must be a non-empty ({height}, {width}) bool array")
    cols = np.flatnonzero(head.any(axis=0))
    top = int(np.flatnonzero(head.any(axis=1))[0])
    left, span = int(cols[0]), int(cols[-1]) - int(cols[0]) + 1
    redness = np.stack(
        [cv2.cvtColor(cv2.GaussianBlur(f, (0, 0), 1.5), cv2.COLOR_RGB2LAB)[..., 1] for f in sample]
    ).astype(np.float32)
    typical = np.median(redness, axis=0)
    change = np.percentile(np.abs(redness - typical), 75, axis=0).astype(np.float32)
    score = cv2.GaussianBlur(change, (0, 0), max(1.0, 0.03 * span))
    region = np.zeros((height, width), bool)
    region[
        top + int(0.85 * span) : top + int(1.4 * span) + 1,
        left + int(0.3 * span) : left + int(0.7 * span) + 1,
    ] = True
    if not region.any():
        raise MiketalkError("the head is too close to the frame's bottom to find its mouth")
    masked = np.where(region, score, -np.inf)
    py, px = np.unravel_index(int(np.argmax(masked)), masked.shape)
    ry, rx = max(1, int(0.12 * span)), max(1, int(0.2 * span))
    ys, xs = slice(max(0, py - ry), py + ry + 1), slice(max(0, px - rx), px + rx + 1)
    yy, xx = np.mgrid[ys, xs]
    moving = np.maximum(score[ys, xs] - 0.5 * score[py, px], 0.0)
    cx = (moving * xx).sum() / moving.sum()
    lips = typical[ys, xs] - np.median(typical[head])
    lips = np.maximum(lips - 0.5 * lips.max(), 0.0)
    cy = (lips * yy).sum() / lips.sum() if lips.sum() > 0 else float(py)
    bw = min(width, max(8, round(size[0] * span)))
    bh = min(height, max(8, round(size[1] * span)))
    x0 = min(max(0, round(cx - bw / 2)), width - bw)
    y0 = min(max(0, round(cy - bh / 2)), height - bh)
    return int(x0), int(y0), int(bw), int(bh)


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


# ---------------------------------------------------------------------------
# the table
# ---------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------
# the summary
# ---------------------------------------------------------------------------


def summarize_inbetween(table: pd.DataFrame, *, baseline: str = _DISSOLVE) -> pd.DataFrame:
    """Mean and spread over clips of each method's per-clip mean, by ``k``.

    Each clip counts once: its PSNR and SSIM are first averaged over its
    frames, then the clips' means are averaged. The gain over ``baseline`` is
    paired: per clip, the method's mean minus the baseline's.

    Parameters
    ----------
    table : pandas.DataFrame
        Rows of :func:`inbetween_table` (any number of clips).
    baseline : str, keyword-only
        The method gains are measured against (the dissolve).

    Returns
    -------
    pandas.DataFrame
        One row per (k, method), in the table's method order, with columns
        ``k``, ``method``, ``clips``, ``frames``, ``psnr_mean``, ``psnr_sd``,
        ``ssim_mean``, ``ssim_sd`` (sd: standard deviation over clips, 0 for
        one clip), ``gain_mean``, ``gain_sd`` (dB over ``baseline``) and
        ``clips_better`` (clips where the method's mean PSNR beats the
        baseline's; NaN columns when the baseline is not in the table).

    Raises
    ------
    MiketalkError
        If the table lacks a column of :data:`COLUMNS` or is empty.
    """
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise MiketalkError(f"the table lacks column(s) {missing}")
    if table.empty:
        raise MiketalkError("the table is empty")
    order = list(dict.fromkeys(table["method"]))
    per_clip = (
        table.groupby(["k", "method", "clip"], sort=False)
        .agg(psnr=("psnr_mouth", "mean"), ssim=("ssim_mouth", "mean"), frames=("t", "size"))
        .reset_index()
    )
    base = per_clip[per_clip["method"] == baseline].set_index(["k", "clip"])["psnr"]
    per_clip["gain"] = per_clip["psnr"].to_numpy() - base.reindex(
        pd.MultiIndex.from_frame(per_clip[["k", "clip"]])
    ).to_numpy(dtype=float)
    rows = []
    for (k, method), group in per_clip.groupby(["k", "method"], sort=False):
        sd = 1 if len(group) > 1 else 0
        gain = group["gain"]
        rows.append(
            {
                "k": int(k),
                "method": method,
                "clips": len(group),
                "frames": int(group["frames"].sum()),
                "psnr_mean": group["psnr"].mean(),
                "psnr_sd": group["psnr"].std(ddof=sd),
                "ssim_mean": group["ssim"].mean(),
                "ssim_sd": group["ssim"].std(ddof=sd),
                "gain_mean": gain.mean(),
                "gain_sd": gain.std(ddof=sd),
                "clips_better": int((gain > 0).sum()) if gain.notna().all() else np.nan,
            }
        )
    summary = pd.DataFrame(rows)
    summary["_order"] = summary["method"].map({m: i for i, m in enumerate(order)})
    summary = summary.sort_values(["k", "_order"]).drop(columns="_order")
    return summary.reset_index(drop=True)


def summary_markdown(summary: pd.DataFrame, *, baseline: str = _DISSOLVE) -> str:
    """The summary as two markdown tables (PSNR with the gain over ``baseline``, and SSIM).

    Rows are methods, columns the ``k``; a cell reads ``mean ± sd`` over clips,
    the PSNR cells followed by the paired gain over ``baseline`` and how many
    clips beat it.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`summarize_inbetween`'s result.
    baseline : str, keyword-only
        The baseline's name (its own gain is not shown).

    Returns
    -------
    str
        Markdown, ending with a newline.
    """
    ks = sorted(summary["k"].unique())
    methods = list(dict.fromkeys(summary["method"]))
    cells = summary.set_index(["method", "k"])
    clips = int(summary["clips"].max())
    head = "| method | " + " | ".join(f"k = {k}" for k in ks) + " |"
    rule = "| --- |" + " --- |" * len(ks)
    psnr_lines = [
        f"Mouth-region PSNR (dB), mean ± sd over {clips} clips; in brackets the paired gain "
        f"over {baseline} (mean ± sd) and the clips where it is positive.",
        "",
        head,
        rule,
    ]
    ssim_lines = [f"Mouth-region SSIM, mean ± sd over {clips} clips.", "", head, rule]
    for method in methods:
        p_cells, s_cells = [], []
        for k in ks:
            if (method, k) not in cells.index:
                p_cells.append("")
                s_cells.append("")
                continue
            row = cells.loc[(method, k)]
            text = f"{row['psnr_mean']:.2f} ± {row['psnr_sd']:.2f}"
            if method != baseline and pd.notna(row["gain_mean"]):
                text += (
                    f" ({row['gain_mean']:+.2f} ± {row['gain_sd']:.2f}, "
                    f"{int(row['clips_better'])}/{int(row['clips'])})"
                )
            p_cells.append(text)
            s_cells.append(f"{row['ssim_mean']:.4f} ± {row['ssim_sd']:.4f}")
        psnr_lines.append(f"| {method} | " + " | ".join(p_cells) + " |")
        ssim_lines.append(f"| {method} | " + " | ".join(s_cells) + " |")
    return "\n".join(psnr_lines) + "\n\n" + "\n".join(ssim_lines) + "\n"
