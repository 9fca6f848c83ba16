"""Coarticulation learned from the person's own speech (beyond the paper; its §10 limitation).

The paper's lip-sync (:mod:`miketalk.talk.lipsync`) runs every transition from
one viseme image all the way to the next: each phone's viseme is reached in
full at the phone's middle, however short the phone. Real lips undershoot short
phones and anticipate the next one. This module replaces the piecewise-linear
path by the Cohen-Massaro dominance model (Cohen & Massaro 1993), whose
parameters are fitted to the recording, as the paper's successor learned its
trajectories from the recording (Ezzat, Geiger & Poggio 2002).

Model
-----
Keyframe ``i`` (one per phone at its middle, two for a diphthong; see
:func:`miketalk.talk.lipsync.keyframes`) with viseme ``V_i`` at time ``c_i``
has the dominance

.. math:: D_i(t) = a_{V_i} \\exp(-\\theta_{V_i} |t - (c_i - \\ell)|)

where ``a_V`` is the viseme's magnitude (how strongly it holds the mouth),
``theta_V`` its rate (1/s; how quickly its hold fades) and ``ell`` an
anticipation lead (s) common to all visemes: the mouth reaches for a phone's
viseme ``ell`` seconds before the phone's middle. Only keyframes within
``window`` seconds of ``t`` (and always the nearest one) count. The mouth at
``t`` is the blend of the visemes with weights ``w_i(t) = D_i(t) / sum_j D_j(t)``
(a viseme's weights summed over its keyframes). A short phone between two
dominant ones is then never reached in full: undershoot.

Fitting
-------
:func:`fit` takes the aligned phones of the training clips and the eigenlip
coordinates (:class:`miketalk.evaluation.heldout.Eigenlips`) of their real
frames and of the viseme images, and chooses ``log a``, ``log theta`` and
``ell`` minimizing the squared distance between the predicted trajectory
``sum_V w_V(t) E(V)`` and the real one, each clip's trajectories with their
moving average over ``detrend`` seconds removed (:func:`detrender`): what
moves slower than that follows lighting and the head pose the stabilization
left rather than the mouth, and is not the model's to predict (fitted
without it, broad dominances of seconds fitted those drifts). ``ell`` is
chosen on a grid; for each grid value ``log a`` and ``log theta`` are found by
Levenberg-Marquardt with a finite-difference Jacobian (numpy only), kept in
plausible bounds, with a weak pull towards the prior ``a = 1``,
``theta = prior_rate`` so that a viseme seen rarely keeps the prior.
The training loss of the paper's own timeline (the same frames through
:func:`miketalk.talk.lipsync.plan`) is stored beside the fitted one.

:func:`fit_coarticulation` runs it for a face built from clips and writes the
parameters as data (``coarticulation.json`` in the model directory);
:func:`read_params` reads them back.

Rendering
---------
:func:`frame_weights` gives every frame of a timeline its visemes and weights,
the ``max_visemes`` largest, those under ``min_weight`` dropped, renormalized;
:func:`miketalk.multimorph.render_learned` draws them.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.types import Phone
from miketalk.talk.lipsync import Keyframe, Timeline
from miketalk.visemes import VisemeTable

log = logging.getLogger(__name__)

__all__ = [
    "FILENAME",
    "FORMAT",
    "LIPSYNC_MODELS",
    "CoarticulationParams",
    "TrainingClip",
    "dominance_weights",
    "fit",
    "fit_coarticulation",
    "frame_weights",
    "paper_trajectory",
    "predict_trajectory",
    "read_params",
    "training_clips",
    "write_params",
]

#: The file the fitted parameters are written to, in the model directory.
FILENAME = "coarticulation.json"

#: Format tag of :data:`FILENAME`.
FORMAT = "miketalk-coarticulation/1"

#: The ``lipsync.model`` settings: the paper's transitions, or the learned dominance blend.
LIPSYNC_MODELS = ("paper", "learned")

#: Default rate of the prior (1/s): a dominance falls to 1/e in 1/12 s (about 2 frames at 25 fps).
PRIOR_RATE = 12.0

#: Anticipation leads tried by :func:`fit` (s).
LEAD_GRID = (-0.04, -0.02, 0.0, 0.02, 0.04, 0.06)


@dataclass(frozen=True)
class CoarticulationParams:
    """Fitted dominance parameters (see the module docstring).

    Attributes
    ----------
    magnitude : dict
        ``viseme -> a_V`` (> 0).
    rate : dict
        ``viseme -> theta_V`` in 1/s (> 0).
    lead : float
        Anticipation ``ell`` in seconds.
    window : float
        Keyframes farther than this from a frame (s) have no dominance over it.
    max_visemes : int
        Most visemes blended in one rendered frame.
    min_weight : float
        Weights under this are dropped from a rendered frame (then renormalized).
    fit : dict
        How the parameters were fitted (losses, frames, clips); informative only.
    """

    magnitude: dict[str, float]
    rate: dict[str, float]
    lead: float = 0.0
    window: float = 0.35
    max_visemes: int = 3
    min_weight: float = 0.05
    fit: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if set(self.magnitude) != set(self.rate):
            raise MiketalkError("coarticulation: magnitude and rate name different visemes")
        for name, values in (("magnitude", self.magnitude), ("rate", self.rate)):
            bad = {v: x for v, x in values.items() if not (math.isfinite(x) and x > 0)}
            if bad:
                raise MiketalkError(f"coarticulation: {name} must be positive, got {bad}")
        if not (math.isfinite(self.lead) and abs(self.lead) < 1.0):
            raise MiketalkError(f"coarticulation: lead must be under 1 s, got {self.lead}")
        if not self.window > 0:
            raise MiketalkError(f"coarticulation: window must be positive, got {self.window}")
        if not (isinstance(self.max_visemes, int) and self.max_visemes >= 1):
            raise MiketalkError(f"coarticulation: max_visemes must be >= 1, not {self.max_visemes}")
        if not 0.0 <= self.min_weight < 0.5:
            raise MiketalkError(
                f"coarticulation: min_weight must be in [0, 0.5), got {self.min_weight}"
            )

    @classmethod
    def prior(
        cls, visemes: Sequence[str], *, rate: float = PRIOR_RATE, **settings: Any
    ) -> CoarticulationParams:
        """Every viseme with ``a = 1`` and ``theta = rate`` (what :func:`fit` starts from)."""
        return cls({v: 1.0 for v in visemes}, {v: float(rate) for v in visemes}, **settings)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form written to :data:`FILENAME`."""
        return {
            "format": FORMAT,
            "magnitude": dict(sorted(self.magnitude.items())),
            "rate": dict(sorted(self.rate.items())),
            "lead": self.lead,
            "window": self.window,
            "max_visemes": self.max_visemes,
            "min_weight": self.min_weight,
            "fit": self.fit,
        }

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> CoarticulationParams:
        """Parameters from :meth:`to_dict`'s form.

        Raises
        ------
        MiketalkError
            For another format or a missing or malformed field.
        """
        if doc.get("format") != FORMAT:
            raise MiketalkError(f"not {FORMAT} parameters (format {doc.get('format')!r})")
        try:
            return cls(
                magnitude={str(k): float(v) for k, v in doc["magnitude"].items()},
                rate={str(k): float(v) for k, v in doc["rate"].items()},
                lead=float(doc["lead"]),
                window=float(doc["window"]),
                max_visemes=int(doc["max_visemes"]),
                min_weight=float(doc["min_weight"]),
                fit=dict(doc.get("fit", {})),
            )
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise MiketalkError(f"malformed coarticulation parameters: {err!r}") from None


def write_params(params: CoarticulationParams, directory: str | os.PathLike[str]) -> Path:
    """Write ``params`` to ``directory / coarticulation.json`` (atomically); return the path."""
    from miketalk.media.atomic import write_text_atomic

    path = Path(directory) / FILENAME
    write_text_atomic(path, json.dumps(params.to_dict(), indent=1, allow_nan=False))
    return path


def read_params(directory: str | os.PathLike[str]) -> CoarticulationParams:
    """The parameters :func:`write_params` wrote in a model directory.

    Raises
    ------
    MiketalkError
        If the model has none (it was built without fitting them) or they are malformed.
    """
    path = Path(directory) / FILENAME
    if not path.is_file():
        raise MiketalkError(
            f"the model at {directory} has no learned coarticulation ({FILENAME}): the "
            "workflow fits one into a model built from recorded clips (e.g. results/model/s1); "
            "or use lipsync model 'paper'"
        )
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise MiketalkError(f"cannot read {path}: {err}") from None
    return CoarticulationParams.from_dict(doc)


# ---------------------------------------------------------------------------
# weights
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Pairs:
    """(time, keyframe) pairs within the window: what the dominance is evaluated on."""

    time: np.ndarray  # index of the time of each pair
    viseme: np.ndarray  # index (into the viseme list) of the pair's keyframe
    offset: np.ndarray  # t - c_i, seconds
    n_times: int


def _pairs(
    centres: np.ndarray, viseme_index: np.ndarray, times: np.ndarray, window: float
) -> _Pairs:
    """Every keyframe within ``window`` of each time, and always the nearest one."""
    offset = times[:, None] - centres[None, :]
    near = np.abs(offset) <= window
    near[np.arange(len(times)), np.argmin(np.abs(offset), axis=1)] = True
    t_idx, k_idx = np.nonzero(near)
    return _Pairs(t_idx, viseme_index[k_idx], offset[t_idx, k_idx], len(times))


def _weights_of_pairs(
    pairs: _Pairs, log_a: np.ndarray, log_theta: np.ndarray, lead: float, n_visemes: int
) -> np.ndarray:
    """``(n_times, n_visemes)`` normalized weights from per-viseme log parameters."""
    # dominance in the log domain, shifted per time before exponentiating (no underflow)
    log_d = log_a[pairs.viseme] - np.exp(log_theta[pairs.viseme]) * np.abs(pairs.offset + lead)
    top = np.full(pairs.n_times, -np.inf)
    np.maximum.at(top, pairs.time, log_d)
    d = np.exp(log_d - top[pairs.time])
    weights = np.zeros((pairs.n_times, n_visemes))
    np.add.at(weights, (pairs.time, pairs.viseme), d)
    return weights / weights.sum(axis=1, keepdims=True)


def dominance_weights(
    keys: Sequence[Keyframe],
    times: np.ndarray | Sequence[float],
    params: CoarticulationParams,
) -> tuple[tuple[str, ...], np.ndarray]:
    """Every viseme's weight at each time (the untruncated blend of the module docstring).

    Parameters
    ----------
    keys : sequence of Keyframe
        The keyframes (:func:`miketalk.talk.lipsync.keyframes`), at least one.
    times : array of float
        Seconds.
    params : CoarticulationParams
        Must know every keyframe's viseme.

    Returns
    -------
    (visemes, weights)
        The visemes of ``keys`` (first appearance order) and ``(len(times), len(visemes))``
        weights, each row summing to 1.
    """
    if not keys:
        raise MiketalkError("no keyframes to weigh")
    visemes = tuple(dict.fromkeys(k.viseme for k in keys))
    unknown = [v for v in visemes if v not in params.magnitude]
    if unknown:
        raise MiketalkError(f"coarticulation parameters lack viseme(s) {unknown}")
    index = {v: i for i, v in enumerate(visemes)}
    centres = np.array([k.time for k in keys], float)
    pairs = _pairs(
        centres,
        np.array([index[k.viseme] for k in keys]),
        np.asarray(times, float).reshape(-1),
        params.window,
    )
    log_a = np.log([params.magnitude[v] for v in visemes])
    log_theta = np.log([params.rate[v] for v in visemes])
    return visemes, _weights_of_pairs(pairs, log_a, log_theta, params.lead, len(visemes))


def _truncate(weights: np.ndarray, *, max_visemes: int, min_weight: float) -> np.ndarray:
    """Keep each row's ``max_visemes`` largest weights not under ``min_weight``; renormalize."""
    out = weights.copy()
    if weights.shape[1] > max_visemes:
        # the (n - max_visemes) smallest of each row are dropped
        drop = np.argpartition(weights, weights.shape[1] - max_visemes, axis=1)
        np.put_along_axis(out, drop[:, : weights.shape[1] - max_visemes], 0.0, axis=1)
    largest = out.max(axis=1, keepdims=True)
    out[(out < min_weight) & (out < largest)] = 0.0
    return out / out.sum(axis=1, keepdims=True)


def frame_weights(
    timeline: Timeline, params: CoarticulationParams
) -> list[tuple[tuple[str, float], ...]]:
    """Each frame's visemes and weights, as rendered.

    At most ``params.max_visemes`` visemes per frame, none under
    ``params.min_weight``, weights summing to 1, in the order of the time of
    each viseme's most dominant keyframe (so that a frame of two visemes names
    them as the paper's transition would: source first). A frame's time is its
    middle (a motion-blurred frame's samples are not used: the learned path is
    smooth).
    """
    times = np.array([f.time for f in timeline.frames])
    visemes, weights = dominance_weights(timeline.keyframes, times, params)
    kept = _truncate(weights, max_visemes=params.max_visemes, min_weight=params.min_weight)
    # order: by the centre of the keyframe nearest in time among each viseme's keyframes
    centres = np.array([k.time for k in timeline.keyframes])
    key_visemes = np.array([visemes.index(k.viseme) for k in timeline.keyframes])
    out = []
    for t, row in zip(times, kept, strict=True):
        nonzero = np.flatnonzero(row)
        order = []
        for v in nonzero:
            own = centres[key_visemes == v]
            order.append((own[np.argmin(np.abs(own - t))], int(v)))
        out.append(tuple((visemes[v], float(row[v])) for _, v in sorted(order)))
    return out


# ---------------------------------------------------------------------------
# trajectories and the fit
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class TrainingClip:
    """One training clip in its own time (0 at its first frame).

    Attributes
    ----------
    id : str
        The clip's name.
    phones : tuple of Phone
        Its aligned phones.
    keys : tuple of Keyframe
        Their keyframes (:func:`miketalk.talk.lipsync.keyframes`).
    fps : float
        Frame rate: frame ``k`` is at ``k / fps``.
    real : (n_frames, n) array
        The real frames' coordinates (eigenlips).
    """

    id: str
    phones: tuple[Phone, ...]
    keys: tuple[Keyframe, ...]
    fps: float
    real: np.ndarray

    @property
    def times(self) -> np.ndarray:
        """Each frame's time, seconds."""
        return np.arange(len(self.real)) / self.fps

    def paper_timeline(self, table: VisemeTable) -> Timeline:
        """The paper's timeline of the clip (:func:`miketalk.talk.lipsync.plan`) on its frames."""
        from miketalk.talk.lipsync import plan

        return plan(self.phones, table, fps=self.fps, duration=len(self.real) / self.fps)


def predict_trajectory(
    keys: Sequence[Keyframe],
    times: np.ndarray,
    params: CoarticulationParams,
    targets: Mapping[str, np.ndarray],
    *,
    rendered: bool = False,
) -> np.ndarray:
    """``sum_V w_V(t) E(V)``: the predicted coordinates ``(len(times), n)``.

    ``rendered=True`` uses the weights as rendered (:func:`frame_weights`'s truncation).
    """
    visemes, weights = dominance_weights(keys, times, params)
    if rendered:
        weights = _truncate(weights, max_visemes=params.max_visemes, min_weight=params.min_weight)
    return weights @ np.stack([targets[v] for v in visemes])


def paper_trajectory(timeline: Timeline, targets: Mapping[str, np.ndarray]) -> np.ndarray:
    """The paper's path in the same coordinates: ``(1 - alpha) E(source) + alpha E(target)``."""
    rows = []
    for f in timeline.frames:
        t = timeline.transitions[f.transition]
        rows.append((1.0 - f.alpha) * targets[t.source] + f.alpha * targets[t.target])
    return np.array(rows)


def detrender(n: int, fps: float, seconds: float) -> np.ndarray:
    """``(n, n)`` matrix removing a trajectory's slow part: ``x - moving_average(x)``.

    The moving average is a box of ``seconds`` (an odd number of frames, edges
    replicated); ``seconds <= 0`` removes the mean only. What moves slower
    than the window (head pose and light the stabilization left, not the
    mouth) is then not fitted.
    """
    if seconds <= 0:
        return np.eye(n) - np.full((n, n), 1.0 / n)
    half = max(1, round(seconds * fps)) // 2
    average = np.zeros((n, n))
    for i in range(n):
        for j in range(i - half, i + half + 1):
            average[i, min(max(j, 0), n - 1)] += 1.0 / (2 * half + 1)
    return np.eye(n) - average


def fit(
    clips: Sequence[TrainingClip],
    targets: Mapping[str, np.ndarray],
    *,
    visemes: Sequence[str] | None = None,
    leads: Sequence[float] = LEAD_GRID,
    prior_rate: float = PRIOR_RATE,
    prior_strength: float = 1e-3,
    detrend: float = 0.6,
    rate_bounds: tuple[float, float] = (4.0, 80.0),
    magnitude_bounds: tuple[float, float] = (0.05, 20.0),
    window: float = 0.35,
    max_visemes: int = 3,
    min_weight: float = 0.05,
    iterations: int = 60,
) -> CoarticulationParams:
    """Fit magnitudes, rates and the lead to real trajectories (see the module docstring).

    Parameters
    ----------
    clips : sequence of TrainingClip
        The training clips, with real coordinates of the same width as ``targets``.
    targets : dict
        ``viseme -> E(V)``, its coordinates (e.g. of the viseme image).
    visemes : sequence of str, optional
        Every viseme to give parameters (default: those of ``targets``); one
        no clip uses keeps the prior.
    leads : sequence of float
        Anticipation leads tried, seconds.
    prior_rate : float
        ``theta`` the fit starts from and is pulled towards, 1/s.
    prior_strength : float
        Weight of the pull towards the prior, relative to the mean squared
        residual per frame and coefficient.
    detrend : float
        Seconds: real and predicted trajectories are compared after removing
        their moving average over this window (:func:`detrender`; 0: each
        clip's mean only).
    rate_bounds, magnitude_bounds : (float, float)
        The range ``theta`` (1/s) and ``a`` are kept in: a dominance that
        lasts for seconds is a drift, not coarticulation.
    window, max_visemes, min_weight
        Stored in the parameters (see :class:`CoarticulationParams`).
    iterations : int
        Levenberg-Marquardt iterations per lead.

    Returns
    -------
    CoarticulationParams
        With ``fit`` holding the training losses (mean squared residual per
        frame and coefficient, centred per clip) of the fitted model, of the
        prior and of the paper's timeline when the clips carry one.
    """
    visemes = tuple(visemes if visemes is not None else targets)
    missing = [v for v in visemes if v not in targets]
    if missing or not clips:
        raise MiketalkError(f"cannot fit: no clips or no targets for {missing}")
    index = {v: i for i, v in enumerate(visemes)}
    e = np.stack([np.asarray(targets[v], float) for v in visemes])
    parts, offsets, real, filters = [], [0], [], []
    for clip in clips:
        for k in clip.keys:
            if k.viseme not in index:
                raise MiketalkError(f"clip {clip.id}: viseme {k.viseme!r} has no target")
        pairs = _pairs(
            np.array([k.time for k in clip.keys]),
            np.array([index[k.viseme] for k in clip.keys]),
            np.asarray(clip.times, float),
            window,
        )
        parts.append(pairs)
        offsets.append(offsets[-1] + pairs.n_times)
        filters.append(detrender(pairs.n_times, clip.fps, detrend))
        real.append(filters[-1] @ np.asarray(clip.real, float))
    # all clips as one set of pairs; a clip's times are numbered after the previous clip's
    pairs = _Pairs(
        np.concatenate([p.time + o for p, o in zip(parts, offsets, strict=False)]),
        np.concatenate([p.viseme for p in parts]),
        np.concatenate([p.offset for p in parts]),
        offsets[-1],
    )
    target = np.concatenate(real)
    bounds = np.array(offsets)
    n_res = target.size
    used = np.bincount(pairs.viseme, minlength=len(visemes)) > 0
    free = np.concatenate([used, used])  # log a, log theta of the visemes seen
    x0 = np.concatenate([np.zeros(len(visemes)), np.full(len(visemes), math.log(prior_rate))])
    reg = math.sqrt(prior_strength * n_res)
    n = len(visemes)
    low = np.log([magnitude_bounds[0]] * n + [rate_bounds[0]] * n)
    high = np.log([magnitude_bounds[1]] * n + [rate_bounds[1]] * n)
    if not (low <= x0).all() or not (x0 <= high).all():
        raise MiketalkError(f"the prior rate {prior_rate} or a = 1 is outside the bounds")

    def predicted(x: np.ndarray, lead: float) -> np.ndarray:
        weights = _weights_of_pairs(pairs, x[: len(visemes)], x[len(visemes) :], lead, len(e))
        p = weights @ e
        # each clip filtered as its real trajectory is
        for (lo, hi), m in zip(pairwise(bounds), filters, strict=True):
            p[lo:hi] = m @ p[lo:hi]
        return p

    def residual(x: np.ndarray, lead: float) -> np.ndarray:
        data = (predicted(x, lead) - target).ravel()
        return np.concatenate([data, reg * (x - x0)[free]])

    def loss(x: np.ndarray, lead: float) -> float:
        return float(np.mean((predicted(x, lead) - target) ** 2))

    best: tuple[float, np.ndarray, float] | None = None
    for lead in leads:
        x = _levenberg_marquardt(
            lambda x, lead=lead: residual(x, lead), x0, free, iterations, low=low, high=high
        )
        value = loss(x, lead)
        log.info("coarticulation fit: lead %.3f s, loss %.4f", lead, value)
        if best is None or value < best[0]:
            best = (value, x, float(lead))
    assert best is not None
    value, x, lead = best
    n = len(visemes)
    info: dict[str, Any] = {
        "detrend": detrend,
        "clips": len(clips),
        "frames": int(offsets[-1]),
        "coefficients": int(e.shape[1]),
        "loss": value,
        "loss_prior": loss(x0, 0.0),
        "frames_per_viseme": {
            v: int(c) for v, c in zip(visemes, np.bincount(pairs.viseme, minlength=n), strict=True)
        },
    }
    return CoarticulationParams(
        magnitude={v: float(np.exp(x[i])) for i, v in enumerate(visemes)},
        rate={v: float(np.exp(x[n + i])) for i, v in enumerate(visemes)},
        lead=lead,
        window=window,
        max_visemes=max_visemes,
        min_weight=min_weight,
        fit=info,
    )


def _levenberg_marquardt(
    residual: Any,
    x0: np.ndarray,
    free: np.ndarray,
    iterations: int,
    *,
    low: np.ndarray,
    high: np.ndarray,
    step: float = 1e-5,
) -> np.ndarray:
    """Minimize ``|residual(x)|^2`` over ``x[free]`` within ``[low, high]``.

    Forward-difference Jacobian; each step is projected into the bounds.
    """
    x = x0.copy()
    r = residual(x)
    cost = float(r @ r)
    damping = 1e-2
    idx = np.flatnonzero(free)
    for _ in range(iterations):
        jac = np.empty((r.size, idx.size))
        for j, i in enumerate(idx):
            xi = x.copy()
            xi[i] += step if x[i] + step <= high[i] else -step
            jac[:, j] = (residual(xi) - r) / (xi[i] - x[i])
        g = jac.T @ r
        h = jac.T @ jac
        improved = False
        for _ in range(10):
            delta = np.linalg.solve(h + damping * np.diag(np.diag(h) + 1e-12), -g)
            trial = x.copy()
            trial[idx] += np.clip(delta, -2.0, 2.0)
            trial = np.clip(trial, low, high)
            r_trial = residual(trial)
            c_trial = float(r_trial @ r_trial)
            if c_trial < cost:
                x, r, improved = trial, r_trial, True
                relative = (cost - c_trial) / max(cost, 1e-300)
                cost = c_trial
                damping = max(damping / 3.0, 1e-9)
                break
            damping *= 4.0
        if not improved or relative < 1e-9:
            break
    return x


# ---------------------------------------------------------------------------
# a face built from clips
# ---------------------------------------------------------------------------


def training_clips(
    corpus_dir: str | os.PathLike[str],
    coordinates: np.ndarray,
    *,
    table: VisemeTable,
) -> list[TrainingClip]:
    """The corpus folder's clips with their phones, keyframes and real coordinates.

    Parameters
    ----------
    corpus_dir : path
        A corpus folder built from clips (``clips.tsv``; ``phones.tsv`` with
        clip-local ``clip_start``/``clip_end``; ``words.json``).
    coordinates : (n_frames, n) array
        Every corpus frame's coordinates (eigenlips), in frame order.
    table : VisemeTable
        Phone -> viseme map.
    """
    import pandas as pd

    from miketalk.corpus.folder import open_corpus
    from miketalk.talk.lipsync import keyframes

    corpus_dir = Path(corpus_dir)
    fps = float(open_corpus(corpus_dir).fps)
    clips = pd.read_csv(corpus_dir / "clips.tsv", sep="\t", dtype={"clip": str})
    phones = pd.read_csv(corpus_dir / "phones.tsv", sep="\t", dtype={"clip": str})
    out = []
    for row in clips.itertuples(index=False):
        own = phones[phones["clip"] == row.clip].sort_values("index")
        timed = tuple(
            Phone(str(p.phone), float(p.clip_start), float(p.clip_end)) for p in own.itertuples()
        )
        first, n = int(row.first_frame), int(row.frames)
        if first + n > len(coordinates):
            raise MiketalkError(f"clip {row.clip}: frames {first}..{first + n} beyond the corpus")
        real = np.asarray(coordinates[first : first + n], float)
        out.append(TrainingClip(str(row.clip), timed, tuple(keyframes(timed, table)), fps, real))
    return out


def fit_coarticulation(
    corpus_dir: str | os.PathLike[str],
    model_dir: str | os.PathLike[str],
    *,
    grouping: Mapping[str, str] | None = None,
    coefficients: int = 3,
    write: bool = True,
    **settings: Any,
) -> CoarticulationParams:
    """Fit the dominance model of a face built from clips and write it into its model.

    The eigenlips are fitted on the corpus's (training) mouth boxes, as the
    held-out evaluation fits them (:class:`miketalk.evaluation.heldout.Eigenlips`);
    each viseme's target ``E(V)`` is its model image's coordinates.

    Parameters
    ----------
    corpus_dir : path
        The face's corpus folder (training clips only).
    model_dir : path
        The face's model directory; ``coarticulation.json`` is written there.
    grouping : dict, optional
        Viseme grouping overrides (the configuration's ``visemes.grouping``).
    coefficients : int
        Eigenlip coefficients the trajectories are compared on.
    write : bool
        Write :data:`FILENAME` into ``model_dir``.
    **settings
        Passed to :func:`fit` (``leads``, ``prior_rate``, ``window``, ...).

    Returns
    -------
    CoarticulationParams
        The fitted parameters; ``fit`` also holds the paper timeline's training loss.
    """
    from miketalk.corpus.folder import count_frames, frame_path
    from miketalk.media.images import read_image
    from miketalk.mouth import Eigenlips, grey_mouths, mouth_region
    from miketalk.talk.model import Model

    table = VisemeTable(grouping=grouping)
    box = mouth_region(corpus_dir)

    frames_dir = Path(corpus_dir) / "frames"
    mouths = np.stack(
        [
            grey_mouths(read_image(frame_path(frames_dir, k))[None], box)[0]
            for k in range(count_frames(frames_dir))
        ]
    )
    eigenlips = Eigenlips(mouths, n=coefficients)
    model = Model(model_dir)
    try:
        images = np.stack([model.image(v) for v in model.visemes])
    finally:
        model.close()
    coords = eigenlips.project(grey_mouths(images, box))
    targets = dict(zip(model.visemes, coords, strict=True))
    clips = training_clips(corpus_dir, eigenlips.project(mouths), table=table)
    params = fit(clips, targets, visemes=model.visemes, **settings)
    detrend = float(params.fit["detrend"])
    paper = [
        detrender(len(clip.real), clip.fps, detrend)
        @ (paper_trajectory(clip.paper_timeline(table), targets) - clip.real)
        for clip in clips
    ]
    info = dict(params.fit)
    info["loss_paper"] = float(np.mean(np.concatenate(paper) ** 2))
    info["explained_variance"] = [float(v) for v in eigenlips.explained]
    params = CoarticulationParams(**{**params.__dict__, "fit": info})
    log.info(
        "coarticulation: loss %.4f (paper %.4f, prior %.4f), lead %.3f s",
        info["loss"],
        info["loss_paper"],
        info["loss_prior"],
        params.lead,
    )
    if write:
        write_params(params, model_dir)
    return params
