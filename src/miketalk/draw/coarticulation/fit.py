"""Fitting the dominance parameters to a clip corpus's real mouth trajectories."""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from miketalk.draw.coarticulation.params import (
    LEAD_GRID,
    PRIOR_RATE,
    CoarticulationParams,
)
from miketalk.draw.coarticulation.weights import _Pairs, _pairs, _weights_of_pairs, paper_trajectory
from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import Keyframe, Timeline
from miketalk.speech.types import Phone
from miketalk.visemes import VisemeTable
from miketalk.workers import one_blas_thread

if TYPE_CHECKING:
    from miketalk.corpus.eigenlips import CorpusEigenlips

log = logging.getLogger(__name__)


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
        Their keyframes (:func:`miketalk.lipsync.timeline.keyframes`).
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
        """The paper's timeline of the clip on its frames
        (:func:`~miketalk.lipsync.timeline.plan`)."""
        from miketalk.lipsync.timeline import plan

        return plan(self.phones, table, fps=self.fps, duration=len(self.real) / self.fps)


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
    evaluations: int = 200,
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
    evaluations : int
        The most evaluations of the residual per lead, besides the Jacobian's
        (:func:`scipy.optimize.least_squares`'s ``max_nfev``).

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

    import scipy.optimize  # noqa: F401  (its BLAS loaded before one_blas_thread limits it)

    best: tuple[float, np.ndarray, float] | None = None
    with one_blas_thread():  # its Jacobian's products: threads only spin (workers.py)
        for lead in leads:
            x = _least_squares(
                lambda x, lead=lead: residual(x, lead), x0, free, evaluations, low=low, high=high
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


def _least_squares(
    residual: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    free: np.ndarray,
    evaluations: int,
    *,
    low: np.ndarray,
    high: np.ndarray,
) -> np.ndarray:
    """Minimize ``|residual(x)|^2`` over ``x[free]`` within ``[low, high]``, from ``x0``.

    :func:`scipy.optimize.least_squares`: the trust-region reflective method (bounds), a
    forward-difference Jacobian, each parameter scaled by its column's norm
    (``x_scale="jac"``), its default tolerances. On s1's 40 training clips it ends at a
    lower cost than the Levenberg-Marquardt loop written here before, in less time
    (docs/lipsync.md).
    """
    from scipy.optimize import least_squares

    idx = np.flatnonzero(free)

    def of_free(z: np.ndarray) -> np.ndarray:
        x = x0.copy()
        x[idx] = z
        return residual(x)

    found = least_squares(
        of_free, x0[idx], bounds=(low[idx], high[idx]), method="trf", jac="2-point",
        x_scale="jac", max_nfev=evaluations,
    )  # fmt: skip
    x = x0.copy()
    x[idx] = found.x
    return x


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
    from miketalk.lipsync.timeline import keyframes

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
    images: Mapping[str, np.ndarray],
    *,
    grouping: Mapping[str, str] | None = None,
    coefficients: int = 3,
    corpus_eigenlips: CorpusEigenlips | None = None,
    **settings: Any,
) -> CoarticulationParams:
    """Fit the dominance model of a face built from clips to its viseme ``images``.

    The eigenlips are fitted on the corpus's (training) mouth boxes, as the
    held-out evaluation fits them (:class:`miketalk.mouth.Eigenlips`);
    each viseme's target ``E(V)`` is its model image's coordinates.

    Parameters
    ----------
    corpus_dir : path
        The face's corpus folder (training clips only).
    images : mapping
        ``viseme -> (H, W, 3) uint8``: the model's viseme images, in the model's order
        (:meth:`miketalk.model.face.Model.image`).
    grouping : dict, optional
        Viseme grouping overrides (the configuration's ``visemes.grouping``).
    coefficients : int
        Eigenlip coefficients the trajectories are compared on.
    corpus_eigenlips : CorpusEigenlips, optional
        The corpus's eigenlips fitted before
        (:func:`miketalk.corpus.eigenlips.read_eigenlips`); None fits them here.
    **settings
        Passed to :func:`fit` (``leads``, ``prior_rate``, ``window``, ...).

    Returns
    -------
    CoarticulationParams
        The fitted parameters; ``fit`` also holds the paper timeline's training loss.
    """
    from miketalk.corpus.eigenlips import fit_corpus_eigenlips
    from miketalk.mouth import grey_mouths, mouth_region

    table = VisemeTable(grouping=grouping)
    box = mouth_region(corpus_dir)
    if corpus_eigenlips is None:
        corpus_eigenlips = fit_corpus_eigenlips(corpus_dir, n=coefficients)
    elif corpus_eigenlips.coordinates.shape[1] != coefficients:
        raise MiketalkError(
            f"the eigenlips given have {corpus_eigenlips.coordinates.shape[1]} coefficients, "
            f"not {coefficients}"
        )
    eigenlips = corpus_eigenlips.eigenlips
    visemes = tuple(images)
    coords = eigenlips.project(grey_mouths(np.stack([images[v] for v in visemes]), box))
    targets = dict(zip(visemes, coords, strict=True))
    clips = training_clips(corpus_dir, corpus_eigenlips.coordinates, table=table)
    params = fit(clips, targets, visemes=visemes, **settings)
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
    return params
