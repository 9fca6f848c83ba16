"""Trajectories: from timed phones to the mouth's description at every frame.

Two models, fitted to every training frame (:mod:`miketalk.draw.trained.mouths`),
with coarticulation learned from the data rather than assumed:

``window`` (:class:`WindowRegression`)
    a ridge regression from the phone context (Taylor et al. 2017's sliding
    window): for a frame at time ``t``, the phone and its viseme class at
    ``t + k * step`` for ``k = -half .. half``, one-hot, predict the frame's
    description. Anticipation and carry-over are whatever weights the data
    give the phones before and after. The ridge strength is chosen by
    cross-validation over clips.
``regularized`` (:class:`RegularizedTrajectory`)
    MMM's trajectory synthesis (Ezzat, Geiger & Poggio 2002): each phone has a
    mean and a variance of the description over its training frames; the
    trajectory ``y`` minimizes, in each component ``d``,
    ``sum_t (y_t - mu_p(t))^2 / var_p(t) + lambda sum_t (y''_t)^2 / var_d``
    (second differences in seconds, so the same ``lambda`` holds at any
    frame rate): a phone of small variance (a closure) is reached, one of
    large variance yields to its neighbours. ``lambda`` is chosen by
    cross-validation over clips.
``heard`` (:class:`WindowRegression` with ``heard > 0``)
    the ``window`` regression with, beside the phones, the recording's own
    log-mel energies around the frame (:func:`miketalk.speech.acoustic.heard_features`):
    how loud and how open a vowel is, which its phone does not say. Only for
    an utterance driven by a recording (``say --audio``, ``dub``, the held-out
    evaluation); typed text has no recording of the person to hear.

All give :meth:`predict` ``(phones, times, table, recording=None) -> (len(times), n)``;
all are kept as arrays and a JSON-ready dict (:func:`to_arrays`, :func:`from_arrays`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from miketalk.draw.trained.ridge import ridge, ridge_path
from miketalk.draw.trained.training import TrainingSet
from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import TRAJECTORIES
from miketalk.speech.acoustic import Recording, heard_features
from miketalk.speech.types import Phone
from miketalk.visemes import SILENCE, VisemeTable

#: The ``heard`` model's window of the recording: half-width (steps) and step (s).
HEARD_HALF, HEARD_STEP = 6, 0.02

#: Edges (s) of the bins of the distance to the speech in a silence (:func:`pause_features`).
PAUSE_BINS = (0.04, 0.08, 0.16, 0.24, 0.36, 0.5, 0.7, 1.0)

#: Ridge strengths and smoothness weights tried by the cross-validation.
RIDGE_GRID = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0)
SMOOTHNESS_GRID = (1e-8, 3e-8, 1e-7, 3e-7, 1e-6, 3e-6, 1e-5)


def phone_at(phones: Sequence[Phone], times: np.ndarray) -> np.ndarray:
    """Index of the phone spoken at each time (-1 before the first or after the last)."""
    starts = np.array([p.start for p in phones], float)
    ends = np.array([p.end for p in phones], float)
    idx = np.searchsorted(starts, times, side="right") - 1
    inside = (idx >= 0) & (times < ends[np.clip(idx, 0, None)] if len(ends) else False)
    return np.where(inside, idx, -1)


def _viseme_at(phones: Sequence[Phone], idx: np.ndarray, times: np.ndarray, table) -> list[str]:
    """The viseme shown at each time: a diphthong's first nucleus in its first half."""
    out = []
    for i, t in zip(idx, times, strict=True):
        if i < 0:
            out.append(SILENCE)
            continue
        p = phones[i]
        visemes = table.visemes_of(p.name)
        second = len(visemes) > 1 and t >= (p.start + p.end) / 2
        out.append(visemes[1] if second else visemes[0])
    return out


@dataclass(frozen=True)
class Context:
    """The phone and viseme vocabularies the models were fitted with."""

    phones: tuple[str, ...]
    visemes: tuple[str, ...]

    @classmethod
    def of(cls, clips: Sequence[Sequence[Phone]], table: VisemeTable) -> Context:
        """The phones the clips speak (and ``pau``) and ``table``'s visemes."""
        seen = sorted({p.name for clip in clips for p in clip} | {"pau"})
        return cls(tuple(seen), tuple(table.visemes))

    def labels(
        self, phones: Sequence[Phone], times: np.ndarray, table: VisemeTable
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each time's phone and viseme index (-1: a phone the training never saw)."""
        idx = phone_at(phones, times)
        names = ["pau" if i < 0 else phones[i].name for i in idx]
        p_index = {p: k for k, p in enumerate(self.phones)}
        v_index = {v: k for k, v in enumerate(self.visemes)}
        pid = np.array([p_index.get(n, -1) for n in names], np.int64)
        vid = np.array([v_index.get(v, -1) for v in _viseme_at(phones, idx, times, table)])
        return pid, vid


@dataclass(frozen=True)
class WindowRegression:
    """Ridge regression from a window of phone context (see the module docstring)."""

    context: Context
    half: int
    step: float
    weights: np.ndarray  # (n_features, n)
    intercept: np.ndarray  # (n,)
    ridge: float
    pauses: bool = True
    heard: int = 0  # the recording's window half-width (heard_step steps); 0: phones only
    heard_step: float = HEARD_STEP

    def predict(
        self,
        phones: Sequence[Phone],
        times: np.ndarray,
        table: VisemeTable,
        recording: Recording | None = None,
    ) -> np.ndarray:
        """The description ``(len(times), n)`` along the phones (and the recording)."""
        x = window_features(
            self.context, phones, times, table, half=self.half, step=self.step,
            pauses=self.pauses, heard=self.heard, heard_step=self.heard_step, recording=recording,
        )  # fmt: skip
        return x @ self.weights + self.intercept


def window_features(
    context: Context,
    phones: Sequence[Phone],
    times: np.ndarray,
    table: VisemeTable,
    *,
    half: int,
    step: float,
    pauses: bool = True,
    heard: int = 0,
    heard_step: float = HEARD_STEP,
    recording: Recording | None = None,
) -> np.ndarray:
    """The one-hot phone context of :class:`WindowRegression` (float64), and with ``pauses``
    the distances to the speech in a silence (:func:`pause_features`), and with ``heard``
    the recording's window of that half-width (:func:`~miketalk.speech.acoustic.heard_features`).
    """
    if heard and recording is None:
        raise MiketalkError("the heard trajectory needs the utterance's recording")
    times = np.asarray(times, float)
    n_p, n_v = len(context.phones), len(context.visemes)
    width = n_p + n_v
    x = np.zeros((len(times), (2 * half + 1) * width + (2 * len(PAUSE_BINS) + 2) * pauses))
    rows = np.arange(len(times))
    for j, k in enumerate(range(-half, half + 1)):
        pid, vid = context.labels(phones, times + k * step, table)
        ok = pid >= 0
        x[rows[ok], j * width + pid[ok]] = 1.0
        ok = vid >= 0
        x[rows[ok], j * width + n_p + vid[ok]] = 1.0
    if pauses:
        x[:, (2 * half + 1) * width :] = pause_features(phones, times, table)
    if heard:
        x = np.concatenate([x, heard_features(recording, times, half=heard, step=heard_step)], 1)
    return x


def pause_features(phones: Sequence[Phone], times: np.ndarray, table: VisemeTable) -> np.ndarray:
    """In a silence: how long until the speech starts and since it ended, one-hot in bins.

    Before a sentence the mouth takes its first posture well ahead of the
    first phone, and after it relaxes slowly: farther than the window sees.
    ``(len(times), 2 (len(PAUSE_BINS) + 1))``; zero in speech.
    """
    spoken = [p for p in phones if SILENCE not in table.visemes_of(p.name)]
    n_bins = len(PAUSE_BINS) + 1
    out = np.zeros((len(times), 2 * n_bins))
    if not spoken:
        return out
    # by sorted starts and ends, not a (times, phones) table: a 12-minute recording's 17,900
    # frames by its 4,300 phones took 2 GB; the same values (the nearest start after, end
    # before, and whether the latest start's phones reach past the time)
    order = np.argsort([p.start for p in spoken], kind="stable")
    starts = np.array([spoken[i].start for i in order])
    reach = np.maximum.accumulate(np.array([spoken[i].end for i in order]))
    ends = np.sort([p.end for p in spoken])
    latest = np.searchsorted(starts, times, side="right") - 1
    inside = (latest >= 0) & (reach[np.maximum(latest, 0)] > times)
    after = np.searchsorted(starts, times, side="left")
    ahead = np.full(len(times), np.inf)
    ahead[after < len(starts)] = starts[after[after < len(starts)]] - times[after < len(starts)]
    before = np.searchsorted(ends, times, side="right") - 1
    behind = np.full(len(times), np.inf)
    behind[before >= 0] = times[before >= 0] - ends[before[before >= 0]]
    rows = np.arange(len(times))
    for column, gap in ((0, ahead), (n_bins, behind)):
        ok = ~inside & np.isfinite(gap)
        bins = np.searchsorted(PAUSE_BINS, gap[ok])
        out[rows[ok], column + bins] = 1.0
    return out


@dataclass(frozen=True)
class RegularizedTrajectory:
    """MMM-style regularized trajectory synthesis (see the module docstring)."""

    context: Context
    phone_mean: np.ndarray  # (P, n)
    phone_var: np.ndarray  # (P, n)
    viseme_mean: np.ndarray  # (V, n): phones never seen fall back to their viseme
    viseme_var: np.ndarray
    scale: np.ndarray  # (n,) the components' variance
    smoothness: float

    def targets(self, phones: Sequence[Phone], times: np.ndarray, table: VisemeTable):
        """Each time's target mean and variance ``(len(times), n)`` each."""
        pid, vid = self.context.labels(phones, times, table)
        mean = np.where((pid >= 0)[:, None], self.phone_mean[pid], self.viseme_mean[vid])
        var = np.where((pid >= 0)[:, None], self.phone_var[pid], self.viseme_var[vid])
        unknown = (pid < 0) & (vid < 0)
        mean[unknown], var[unknown] = 0.0, self.scale
        return mean, var

    def predict(
        self,
        phones: Sequence[Phone],
        times: np.ndarray,
        table: VisemeTable,
        recording: Recording | None = None,
    ) -> np.ndarray:
        """The trajectory ``(len(times), n)`` of least regularized cost along the phones
        (``recording`` is not used)."""
        times = np.asarray(times, float)
        mean, var = self.targets(phones, times, table)
        return smooth_targets(mean, var, self.scale, self.smoothness, times)


def smooth_targets(
    mean: np.ndarray, var: np.ndarray, scale: np.ndarray, smoothness: float, times: np.ndarray
) -> np.ndarray:
    """Solve ``(W + lambda_d D'D) y = W mu`` per component (banded, symmetric positive)."""
    from scipy.linalg import solveh_banded

    n = len(mean)
    if n < 3:
        return mean.copy()
    dt = float(np.median(np.diff(times))) if n > 1 else 1.0
    # D: second differences in 1/s^2; the cost sums over frames weighted by dt
    # D'D of the second difference, as its upper bands (diagonal last row)
    ones = np.ones(n)
    d0 = 6.0 * ones
    d0[[0, -1]], d0[[1, -2]] = 1.0, 5.0
    d1 = -4.0 * ones[:-1]
    d1[[0, -1]] = -2.0
    d2 = ones[:-2]
    out = np.empty_like(mean)
    for d in range(mean.shape[1]):
        lam = smoothness / scale[d] / dt**4
        weight = 1.0 / var[:, d]
        bands = np.zeros((3, n))
        bands[2] = weight + lam * d0
        bands[1, 1:] = lam * d1
        bands[0, 2:] = lam * d2
        out[:, d] = solveh_banded(bands, weight * mean[:, d])
    return out


def _stats(
    labels: np.ndarray, y: np.ndarray, count: int, floor: np.ndarray, prior: float = 3.0
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of ``y`` per label, shrunk towards the global ones by ``prior`` frames."""
    mean = np.zeros((count, y.shape[1]))
    var = np.zeros((count, y.shape[1]))
    g_mean, g_var = y.mean(axis=0), y.var(axis=0)
    for k in range(count):
        rows = y[labels == k]
        m = len(rows)
        mk = rows.mean(axis=0) if m else g_mean
        vk = rows.var(axis=0) if m else g_var
        mean[k] = (m * mk + prior * g_mean) / (m + prior)
        var[k] = np.maximum((m * vk + prior * g_var) / (m + prior), floor)
    return mean, var


def fit_window(
    data: TrainingSet,
    context: Context,
    table: VisemeTable,
    *,
    half: int = 6,
    step: float = 0.04,
    pauses: bool = True,
    heard: int = 0,
    grid: Sequence[float] = RIDGE_GRID,
    folds: int = 5,
    predictions: dict | None = None,
) -> tuple[WindowRegression, dict]:
    """Fit :class:`WindowRegression` (ridge strength by cross-validation); it and a report.

    With ``heard`` (the recording's window half-width) it hears ``data.recordings``.
    ``predictions``, when given, receives each clip's cross-validated prediction at
    the chosen strength (``clip index -> (frames, n)``: fitted without that clip).
    """
    if heard and data.recordings is None:
        raise MiketalkError("the heard trajectory is fitted on the training clips' recordings")
    recordings = data.recordings if heard else (None,) * len(data.phones)
    settings = {"half": half, "step": step, "pauses": pauses, "heard": heard}
    xs = [
        window_features(context, p, t, table, recording=r, **settings)
        for p, t, r in zip(data.phones, data.times, recordings, strict=True)
    ]
    # fitted and scored on the kept frames (:attr:`TrainingSet.kept`), predicted at every one
    fx, fy, kept = data.fitted_rows(xs), data.fitted_rows(data.coords), data.kept_rows()
    err: dict[float, Any] = dict.fromkeys(grid, 0.0)
    held: dict[float, dict[int, np.ndarray]] = {strength: {} for strength in grid}
    count = 0
    for train, valid in data.folds(folds):
        fits = ridge_path(
            np.concatenate([fx[i] for i in train]), np.concatenate([fy[i] for i in train]), grid
        )
        for strength, (w, b) in zip(grid, fits, strict=True):
            for i in valid:
                held[strength][i] = xs[i] @ w + b
                miss = held[strength][i][kept[i]] - fy[i]
                err[strength] = err[strength] + (miss**2).sum(axis=0)
        count += sum(len(fy[i]) for i in valid)
    errors = {strength: err[strength] / count for strength in grid}
    best = min(errors, key=lambda s: (float(errors[s].mean()), s))
    if predictions is not None:
        predictions.update(held[best])
    w, b = ridge(np.concatenate(fx), np.concatenate(fy), best)
    report = _report(errors, best, data)
    fitted = WindowRegression(context, half, step, w, b, best, pauses, heard)
    return fitted, report | {"ridge": best}


def _report(errors: Mapping[float, np.ndarray], best: float, data: TrainingSet) -> dict:
    """The cross-validation's mean squared error per setting and, at the best, R^2 per component.

    The R^2 of a component (1 - its held-out squared error / its variance) says
    how much of it the phones predict: the selection weighs its target cost by it.
    """
    var = np.concatenate(data.fitted_rows(data.coords)).var(axis=0)
    r2 = np.clip(1.0 - errors[best] / var, 0.0, 1.0)
    return {
        "cv_mse": {str(k): float(v.mean()) for k, v in errors.items()},
        "cv_r2": [round(float(v), 6) for v in r2],
    }


def fit_regularized(
    data: TrainingSet,
    context: Context,
    table: VisemeTable,
    *,
    grid: Sequence[float] = SMOOTHNESS_GRID,
    folds: int = 5,
    predictions: dict | None = None,
) -> tuple[RegularizedTrajectory, dict]:
    """Fit :class:`RegularizedTrajectory` (smoothness by cross-validation); it and a report
    (``predictions`` as :func:`fit_window`)."""
    labels = [context.labels(p, t, table) for p, t in zip(data.phones, data.times, strict=True)]
    kept = data.kept_rows()  # the frames it learns from
    labels = [(pid[k], vid[k]) for (pid, vid), k in zip(labels, kept, strict=True)]
    ys = data.fitted_rows(data.coords)
    y_all = np.concatenate(ys)
    scale = y_all.var(axis=0)
    floor = 1e-3 * scale

    def fitted(clips: Sequence[int], smoothness: float) -> RegularizedTrajectory:
        pid = np.concatenate([labels[i][0] for i in clips])
        vid = np.concatenate([labels[i][1] for i in clips])
        y = np.concatenate([ys[i] for i in clips])
        pm, pv = _stats(pid, y, len(context.phones), floor)
        vm, vv = _stats(vid, y, len(context.visemes), floor)
        return RegularizedTrajectory(context, pm, pv, vm, vv, scale, smoothness)

    errors, held = {}, {}
    for smoothness in grid:
        err, count, held[smoothness] = 0.0, 0, {}
        for train, valid in data.folds(folds):
            model = fitted(train, smoothness)
            for i in valid:
                pred = held[smoothness][i] = model.predict(data.phones[i], data.times[i], table)
                err = err + ((pred[kept[i]] - ys[i]) ** 2).sum(axis=0)
                count += len(ys[i])
        errors[smoothness] = err / count
    best = min(errors, key=lambda s: (float(errors[s].mean()), s))
    if predictions is not None:
        predictions.update(held[best])
    report = _report(errors, best, data) | {"smoothness": best}
    return fitted(range(len(data.phones)), best), report


def to_arrays(model: WindowRegression | RegularizedTrajectory) -> tuple[dict, dict]:
    """``(arrays, settings)``: the model as numpy arrays and a JSON-ready dict."""
    base = {"phones": list(model.context.phones), "visemes": list(model.context.visemes)}
    if isinstance(model, WindowRegression):
        arrays = {"weights": model.weights, "intercept": model.intercept}
        return arrays, base | {
            "kind": "window", "half": model.half, "step": model.step, "ridge": model.ridge,
            "pauses": model.pauses, "heard": model.heard, "heard_step": model.heard_step,
        }  # fmt: skip
    arrays = {
        "phone_mean": model.phone_mean, "phone_var": model.phone_var,
        "viseme_mean": model.viseme_mean, "viseme_var": model.viseme_var, "scale": model.scale,
    }  # fmt: skip
    return arrays, base | {"kind": "regularized", "smoothness": model.smoothness}


def from_arrays(
    arrays: Mapping[str, np.ndarray], settings: Mapping
) -> WindowRegression | RegularizedTrajectory:
    """The model :func:`to_arrays` described."""
    context = Context(tuple(settings["phones"]), tuple(settings["visemes"]))
    kind = settings.get("kind")
    if kind == "window":
        return WindowRegression(
            context, int(settings["half"]), float(settings["step"]), arrays["weights"],
            arrays["intercept"], float(settings["ridge"]), bool(settings.get("pauses", False)),
            int(settings.get("heard", 0)), float(settings.get("heard_step", HEARD_STEP)),
        )  # fmt: skip
    if kind == "regularized":
        return RegularizedTrajectory(
            context, arrays["phone_mean"], arrays["phone_var"], arrays["viseme_mean"],
            arrays["viseme_var"], arrays["scale"], float(settings["smoothness"]),
        )  # fmt: skip
    raise MiketalkError(f"unknown trajectory model {kind!r} (known: {', '.join(TRAJECTORIES)})")
