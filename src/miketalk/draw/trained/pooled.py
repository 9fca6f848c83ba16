"""A person-independent model of the mouth's motion, and its adaptation to one person.

A face built from a few seconds of a person cannot learn from them how his mouth follows
his speech (on six weekly addresses, 14 s, the trained face's own window regression
predicts none of his mouth's description: cross-validated R² 0.00). What is shared between
people is learned once, from every talker there is, and shipped with the package
(:data:`POOLED_FILE`, built by ``python -m miketalk_lab.bench.pooled_mouth``, its
provenance in :data:`PROVENANCE` beside it):

the mouth's geometry
    how far the lips part and the mouth widens, in pixels of the canonical face crop (eyes
    level and 72 px apart: one scale for everyone), measured by dense optical flow (DIS)
    from each clip's median mouth to each of its frames (:func:`mouth_geometry`): the
    mouth region's lower half's mean downward motion less its upper half's, its right
    half's mean motion to the right less its left half's, and the lower half's alone
    (the jaw). A motion, not a look: a
    face's teeth, lips, beard and light are not in it;
the pooled trajectory
    :class:`PooledModel`: a ridge regression from what any speech gives whoever speaks,
    the viseme classes around the frame (not the phones, so that a phone one talker never
    said is not a feature), the distance to the speech in a pause, and the recording's
    standardized log-mel window (:func:`miketalk.speech.acoustic.heard_features`), to
    the geometry.

A new person's few seconds only adapt it (:func:`fit_pooled`): a lag (the pooled
trajectory read up to :data:`LAGS` frames earlier or later: a video whose sound is cut
late against its picture) and a linear map from the pooled geometry to his own (his
training frames measured the same way, :func:`frame_geometry`), 12 numbers chosen by
cross-validation over his clips. The result, :class:`PooledTrajectory`, is the trained
face's ``pooled`` trajectory: his own frames are selected by their geometry along it
(:meth:`~miketalk.draw.trained.build.TrainedFace.described`).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

import numpy as np

from miketalk.draw.trained.ridge import ridge
from miketalk.draw.trained.training import TrainingSet
from miketalk.draw.trained.trajectory import RIDGE_GRID, Context, window_features
from miketalk.draw.trained.trajectory import from_arrays as trajectory_from_arrays
from miketalk.draw.trained.trajectory import to_arrays as trajectory_to_arrays
from miketalk.errors import MiketalkError
from miketalk.speech.acoustic import Recording
from miketalk.speech.types import Phone
from miketalk.visemes import VisemeTable

log = logging.getLogger(__name__)

#: The package's pooled model and its provenance (in ``miketalk/data``).
POOLED_FILE, PROVENANCE = "pooled_mouth.npz", "pooled_mouth.json"
#: The geometry's dimensions.
GEOMETRY = ("opening", "width", "jaw")
#: The lags tried in the adaptation, in frames (positive: the trajectory read later).
LAGS = (-4, -3, -2, -1, 0, 1, 2, 3, 4)


def mouth_geometry(regions: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """``(N, 3)`` :data:`GEOMETRY` of grey mouth regions ``(N, H, W)`` of the canonical crop,
    each by DIS optical flow from its clip's (``clip``: ``(N,)`` labels) pixelwise median
    region (see the module docstring), in crop pixels."""
    import cv2

    regions = np.clip(np.asarray(regions, np.float32), 0, 255)
    out = np.zeros((len(regions), len(GEOMETRY)))
    if not len(regions):
        return out
    h, w = regions.shape[1:]
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    middle = slice(w // 4, 3 * w // 4)
    for c in np.unique(clip):
        rows = np.flatnonzero(clip == c)
        reference = np.median(regions[rows], axis=0).astype(np.uint8)
        for i in rows:
            flow = dis.calc(reference, regions[i].astype(np.uint8), None)
            down, across = flow[..., 1], flow[..., 0]
            lower, upper = down[h // 2 :, middle].mean(), down[: h // 2, middle].mean()
            wider = across[:, w // 2 :].mean() - across[:, : w // 2].mean()
            out[i] = lower - upper, wider, lower
    return out


def frame_geometry(frames) -> np.ndarray:
    """``(N, 3)``: the :func:`mouth_geometry` of a trained face's training frames
    (:class:`~miketalk.draw.trained.mouths.MouthFrames`), each clip from its own median."""
    from miketalk.draw.trained.mouths import grey

    px, py, _, _ = frames.patch
    rx, ry, rw, rh = frames.region
    out = np.zeros((len(frames.coords), len(GEOMETRY)))
    for c in range(len(frames.clip_ids)):  # a clip's patches at a time (memory-mapped)
        rows = np.flatnonzero(frames.clip == c)
        region = frames.patches[rows, ry - py : ry - py + rh, rx - px : rx - px + rw]
        out[rows] = mouth_geometry(grey(region), np.zeros(len(rows)))
    return out


@dataclass(frozen=True)
class PooledModel:
    """The person-independent trajectory (see the module docstring).

    Attributes
    ----------
    visemes : tuple of str
        The viseme classes of its features (the default table's).
    half, step : int, float
        The viseme window: ``half`` steps of ``step`` seconds each side.
    heard, heard_step : int, float
        The recording's window.
    weights, intercept : arrays
        ``(V, features, 3)`` and ``(V, 3)``: to the :data:`GEOMETRY`, one regression per
        variant (the same data fitted with other features and regularization).
    variants : tuple of str
        The variants' names (``features:ridge``), which a face's adaptation chooses from.
    digest : str
        The file's SHA-256, which a face adapted to it records.
    """

    visemes: tuple[str, ...]
    half: int
    step: float
    heard: int
    heard_step: float
    weights: np.ndarray
    intercept: np.ndarray
    variants: tuple[str, ...]
    digest: str

    @property
    def context(self) -> Context:
        """The features' vocabulary: visemes only."""
        return Context((), self.visemes)

    def features(
        self, phones: Sequence[Phone], times: np.ndarray, table: VisemeTable, recording: Recording
    ) -> np.ndarray:
        """The regression's inputs at ``times``."""
        return window_features(
            self.context, phones, times, table, half=self.half, step=self.step, pauses=True,
            heard=self.heard, heard_step=self.heard_step, recording=recording,
        )  # fmt: skip

    def predict(
        self,
        phones: Sequence[Phone],
        times: np.ndarray,
        table: VisemeTable,
        recording: Recording | None = None,
        variant: int = 0,
    ) -> np.ndarray:
        """The geometry ``(len(times), 3)`` along the phones and the recording, by the
        regression ``variant``."""
        return self.every_variant(phones, times, table, recording, (variant,))[0]

    def every_variant(
        self,
        phones: Sequence[Phone],
        times: np.ndarray,
        table: VisemeTable,
        recording: Recording | None,
        variants: Sequence[int] | None = None,
    ) -> list[np.ndarray]:
        """The geometry by each of ``variants`` (default all), the features computed once."""
        if recording is None:
            raise MiketalkError("the pooled trajectory listens to a recording: give one")
        x = self.features(phones, np.asarray(times, float), table, recording)
        chosen = range(len(self.variants)) if variants is None else variants
        return [x @ self.weights[v] + self.intercept[v] for v in chosen]


def read_pooled(path=None) -> PooledModel:
    """The pooled model in ``path`` (default the package's :data:`POOLED_FILE`).

    Raises
    ------
    MiketalkError
        In one line, when it is missing or malformed.
    """
    try:
        if path is None:
            data = resources.files("miketalk").joinpath(f"data/{POOLED_FILE}").read_bytes()
        else:
            with open(path, "rb") as f:
                data = f.read()
        import io

        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        settings = json.loads(str(arrays.pop("settings")))
        return PooledModel(
            tuple(settings["visemes"]), int(settings["half"]), float(settings["step"]),
            int(settings["heard"]), float(settings["heard_step"]), arrays["weights"],
            arrays["intercept"], tuple(settings["variants"]), hashlib.sha256(data).hexdigest(),
        )  # fmt: skip
    except (OSError, ValueError, KeyError, TypeError) as err:
        where = path or POOLED_FILE
        raise MiketalkError(f"cannot read the pooled mouth model {where}: {err}") from None


@lru_cache(maxsize=1)
def package_pooled() -> PooledModel:
    """The package's pooled model, read once."""
    return read_pooled()


@dataclass(frozen=True)
class PooledTrajectory:
    """The pooled trajectory adapted to one person: its regression ``variant`` read ``lag``
    seconds later, mapped linearly to his geometry (``weights`` ``(3, 3)``, ``intercept``
    ``(3,)``); ``geometry`` ``(N, 3)`` is his training frames' (:func:`frame_geometry`),
    what the selection compares the prediction with."""

    pooled: PooledModel
    lag: float
    weights: np.ndarray
    intercept: np.ndarray
    ridge: float
    geometry: np.ndarray
    variant: int = 0

    @property
    def context(self) -> Context:
        """The pooled model's vocabulary (the selection reads its visemes)."""
        return self.pooled.context

    def predict(
        self,
        phones: Sequence[Phone],
        times: np.ndarray,
        table: VisemeTable,
        recording: Recording | None = None,
    ) -> np.ndarray:
        """His geometry ``(len(times), 3)`` along the phones and the recording."""
        times = np.asarray(times, float) + self.lag
        shared = self.pooled.predict(phones, times, table, recording, self.variant)
        return shared @ self.weights + self.intercept

    def cost_weights(self, variance: np.ndarray) -> np.ndarray:
        """The selection's weight of each dimension, so that a miss of one spread in each
        costs as much as a miss of one spread in each of the description's components
        (their ``variance``) does. Not weighted by the adaptation's R², unlike the other
        trajectories' components: the few dimensions are the mouth's motion itself, and
        their scatter about the prediction is mostly the flow's measurement noise."""
        spread = np.maximum(self.geometry.var(axis=0), 1e-9)
        return np.full(len(spread), float(np.sum(variance)) / len(spread)) / spread


def fit_pooled(
    data: TrainingSet,
    table: VisemeTable,
    geometry: np.ndarray,
    *,
    pooled: PooledModel | None = None,
    grid: Sequence[float] = RIDGE_GRID,
    folds: int = 5,
    predictions: dict | None = None,
) -> tuple[PooledTrajectory, dict]:
    """Adapt the pooled model to a face's training clips, whose frames' geometry is
    ``geometry`` (``(N, 3)``, the clips' frames in order): the pooled regression's variant,
    the lag and the ridge strength of the map by cross-validation over clips (``folds``),
    then the map fitted to all.

    Returns the trajectory and a report (as :func:`~.trajectory.fit_window`'s, in the
    geometry's dimensions: ``cv_mse`` per setting, ``cv_r2``, ``ridge``, ``lag`` in frames,
    ``variant``, ``amplitude_gain`` and ``amplitude_gain_cv``). ``predictions`` receives each clip's
    cross-validated prediction, as there.
    """
    from miketalk.draw.trained.gains import spread_ratio

    if data.recordings is None:
        raise MiketalkError("the pooled trajectory is adapted on the training clips' recordings")
    pooled = pooled or package_pooled()
    dt = _frame_step(data)
    bounds = np.cumsum([0, *(len(t) for t in data.times)])
    kept = data.kept_rows()  # the frames it learns from
    rows = np.concatenate([a + k for a, k in zip(bounds[:-1], kept, strict=True)])
    real = data.fitted_rows([geometry[a:b] for a, b in itertools.pairwise(bounds)])
    shared = {}  # (variant, lag) -> each clip's pooled geometry
    for lag in LAGS:
        clips = [
            pooled.every_variant(p, t + lag * dt, table, r)
            for p, t, r in zip(data.phones, data.times, data.recordings, strict=True)
        ]
        for v in range(len(pooled.variants)):
            shared[v, lag] = [c[v] for c in clips]  # every frame, predicted
    fitted = {key: data.fitted_rows(inputs) for key, inputs in shared.items()}
    errors, held = {}, {}
    for (v, lag), inputs in shared.items():
        learnt = fitted[v, lag]
        for strength in grid:
            key = (v, lag, strength)
            err, count, held[key] = 0.0, 0, {}
            for train, valid in data.folds(folds):
                w, b = ridge(
                    np.concatenate([learnt[i] for i in train]),
                    np.concatenate([real[i] for i in train]),
                    strength,
                )
                for i in valid:
                    held[key][i] = inputs[i] @ w + b
                    err = err + ((held[key][i][kept[i]] - real[i]) ** 2).sum(axis=0)
                    count += len(real[i])
            errors[key] = err / count
    # the least error over the dimensions' spreads (each dimension counts alike)
    spread = np.maximum(geometry[rows].var(axis=0), 1e-12)
    best = min(errors, key=lambda k: (float((errors[k] / spread).mean()), abs(k[1]), k[0], k[2]))
    if predictions is not None:
        predictions.update(held[best])
    v, lag, strength = best
    w, b = ridge(np.concatenate(fitted[v, lag]), geometry[rows], strength)
    r2 = np.clip(1.0 - errors[best] / geometry[rows].var(axis=0), 0.0, 1.0)
    report = {
        "cv_mse": {
            f"{pooled.variants[k[0]]}:{k[1]}:{k[2]}": float(e.mean()) for k, e in errors.items()
        },
        "cv_r2": [round(float(x), 6) for x in r2],
        "ridge": strength,
        "lag": lag,
        "variant": pooled.variants[v],
        "pooled": pooled.digest,
        "amplitude_gain": spread_ratio([x @ w + b for x in fitted[v, lag]], real),
        "amplitude_gain_cv": spread_ratio(
            data.fitted_rows([held[best][i] for i in range(len(real))]), real
        ),
    }
    return PooledTrajectory(pooled, lag * dt, w, b, strength, geometry, v), report


def _frame_step(data: TrainingSet) -> float:
    """The training frames' time step (s)."""
    steps = np.concatenate([np.diff(t) for t in data.times if len(t) > 1])
    return float(np.median(steps)) if len(steps) else 0.04


def to_arrays(model) -> tuple[dict, dict]:
    """``(arrays, settings)`` of any trajectory model
    (:func:`miketalk.draw.trained.trajectory.to_arrays`), an adapted one's pooled model
    named by its digest."""
    if not isinstance(model, PooledTrajectory):
        return trajectory_to_arrays(model)
    arrays = {"weights": model.weights, "intercept": model.intercept, "geometry": model.geometry}
    settings = {"kind": "pooled", "lag": model.lag, "ridge": model.ridge,
                "pooled": model.pooled.digest, "variant": model.variant}  # fmt: skip
    return arrays, settings


def from_arrays(arrays, settings):
    """The trajectory model :func:`to_arrays` described; an adapted one on the package's
    pooled model, or None when that is not the one the face was adapted to (the face then
    has no ``pooled`` trajectory: rebuild it to have one)."""
    if settings.get("kind") != "pooled":
        return trajectory_from_arrays(arrays, settings)
    pooled = package_pooled()
    if settings.get("pooled") != pooled.digest:
        log.warning("this trained face was adapted to another pooled mouth model: not used")
        return None
    return PooledTrajectory(
        pooled, float(settings["lag"]), arrays["weights"], arrays["intercept"],
        float(settings["ridge"]), arrays["geometry"], int(settings["variant"]),
    )  # fmt: skip


__all__ = [
    "GEOMETRY",
    "LAGS",
    "POOLED_FILE",
    "PROVENANCE",
    "PooledModel",
    "PooledTrajectory",
    "fit_pooled",
    "frame_geometry",
    "from_arrays",
    "mouth_geometry",
    "package_pooled",
    "read_pooled",
    "to_arrays",
]
