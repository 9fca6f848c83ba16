"""How much of the mouth the phones predict: the trajectory's cross-validated R², by model.

``python -m miketalk_lab.bench.trajectory_cv --corpus DIR [--mlp 128 512] [--heard] [--opening]
[--voice kal ked]``

The trained face's description of every frame of a corpus folder
(:func:`miketalk.draw.trained.mouths.measure_frames`) predicted from the phone
context (:func:`miketalk.draw.trained.trajectory.window_features`), 5-fold over
clips (every 5th clip held out, as the model's own fit does): the ridge of the
``window`` trajectory at each window half-width and strength, and, with
``--mlp``, scikit-learn's ``MLPRegressor`` on the same features (one hidden
layer of each given size; scikit-learn is not a miketalk dependency: install it
to try this). Prints, per model, the R² of the first components and the R² of
the whole description (1 - mean squared error / mean variance). Training clips
only: the ceiling a phone model meets, judged without the held-out clips.

``--voice kal ked`` asks whether the ``heard`` trajectory holds for another
speaker: fitted on his recordings as always, it meets each held-out clip spoken
by that Festival voice at his own phone timing (:mod:`miketalk_lab.bench.other_voice`).

``--heard`` adds the ``heard`` trajectory's features (the clip's recording,
:func:`miketalk.speech.acoustic.heard_features`) beside the phones. ``--opening``
asks the question in the held-out evaluation's own terms, without the description
or the selection in between: dlib marks every training frame (evaluation only), and
the same ridge predicts the inner-lip opening itself, phones alone and phones with
the recording; printed is the mean over clips of the cross-validated prediction's
correlation with the real opening over the speech (and its amplitude), beside the
real opening one frame late.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench

if TYPE_CHECKING:
    from miketalk.draw.trained.training import TrainingSet

Fit = Callable[[np.ndarray, np.ndarray, Sequence[np.ndarray]], list[np.ndarray]]


def cross_validated_r2(
    xs: Sequence[np.ndarray],
    ys: Sequence[np.ndarray],
    fit: Fit,
    *,
    folds: int = 5,
    held_xs: Sequence[np.ndarray] | None = None,
) -> tuple[float, np.ndarray]:
    """``(whole, per component)`` R² of ``fit`` over clips, every ``folds``-th clip held out.

    ``held_xs`` (default ``xs``) are the held-out clips' features as the fitted model
    meets them: the same clips heard in another voice, say."""
    n = len(xs)
    held_xs = xs if held_xs is None else held_xs
    err, count = np.zeros(ys[0].shape[1]), 0
    for f in range(min(folds, n)):
        train = [i for i in range(n) if i % folds != f]
        valid = [i for i in range(n) if i % folds == f]
        x, y = np.concatenate([xs[i] for i in train]), np.concatenate([ys[i] for i in train])
        for i, pred in zip(valid, fit(x, y, [held_xs[i] for i in valid]), strict=True):
            err += ((pred - ys[i]) ** 2).sum(axis=0)
            count += len(pred)
    var = np.concatenate(ys).var(axis=0)
    mse = err / count
    return float(1.0 - mse.mean() / var.mean()), 1.0 - mse / var


def ridge_fit(strength: float) -> Fit:
    """The ``window`` trajectory's ridge (:func:`miketalk.draw.trained.trajectory.ridge`)."""
    from miketalk.draw.trained.ridge import ridge

    def fit(x: np.ndarray, y: np.ndarray, held: Sequence[np.ndarray]) -> list[np.ndarray]:
        w, b = ridge(x, y, strength)
        return [v @ w + b for v in held]

    return fit


def mlp_fit(hidden: int, alpha: float) -> Fit:
    """scikit-learn's MLPRegressor (one hidden layer, early stopping) on standardized targets."""
    try:
        from sklearn.neural_network import MLPRegressor
    except ImportError:
        raise MiketalkError("--mlp needs scikit-learn (pip install scikit-learn)") from None

    def fit(x: np.ndarray, y: np.ndarray, held: Sequence[np.ndarray]) -> list[np.ndarray]:
        mu, sd = y.mean(axis=0), y.std(axis=0)
        net = MLPRegressor(
            hidden_layer_sizes=(hidden,), alpha=alpha, max_iter=200, early_stopping=True,
            random_state=0, batch_size=256,
        )  # fmt: skip
        net.fit(x, (y - mu) / sd)
        return [net.predict(v) * sd + mu for v in held]

    return fit


def opening_ceiling(
    corpus: Path,
    data: TrainingSet,
    clip_ids: Sequence[str],
    xs: dict[str, list[np.ndarray]],
    strengths: Sequence[float],
) -> list[str]:
    """The cross-validated ridge's opening r and amplitude over the speech, per feature set
    and strength (see the module docstring); the real opening one frame late first."""
    import pandas as pd

    from miketalk.corpus.folder import frame_path
    from miketalk.draw.trained.ridge import ridge
    from miketalk.media.images import read_image
    from miketalk.visemes import SILENCE, VisemeTable
    from miketalk_lab.evaluation.landmarks import face_landmarks, lip_opening
    from miketalk_lab.evaluation.measures import correlation

    table = VisemeTable()
    frames = pd.read_csv(corpus / "frames.tsv", sep="\t", dtype={"clip": str})
    openings, speech = [], []
    landmarks = face_landmarks()
    box = None
    for phones, times, clip in zip(data.phones, data.times, clip_ids, strict=True):
        rows = frames[frames["clip"] == clip].sort_values("clip_frame")["frame"].to_numpy()
        real = np.stack([read_image(frame_path(corpus / "frames", int(k))) for k in rows])
        box = box or landmarks.face_box(real)
        openings.append(lip_opening(landmarks.points(real, box))[: len(times)])
        spoken = [p for p in phones if SILENCE not in table.visemes_of(p.name)]
        speech.append((times >= spoken[0].start) & (times < spoken[-1].end))

    def scores(predicted: Sequence[np.ndarray]) -> tuple[float, float]:
        r = [correlation(p[m], o[m]) for p, o, m in zip(predicted, openings, speech, strict=True)]
        a = [p[m].std() / o[m].std() for p, o, m in zip(predicted, openings, speech, strict=True)]
        return float(np.nanmean(r)), float(np.mean(a))

    late = [np.r_[o[:1], o[:-1]] for o in openings]
    r, a = scores(late)
    lines = [f"opening r {r:.3f}, amplitude {a:.2f}: the real opening one frame late"]
    targets = [o[:, None] for o in openings]
    for name, x in xs.items():
        for strength in strengths:
            held: list[np.ndarray] = [np.empty(0)] * len(x)
            for train, valid in data.folds(5):
                w, b = ridge(np.concatenate([x[i] for i in train]),
                             np.concatenate([targets[i] for i in train]), strength)  # fmt: skip
                for i in valid:
                    held[i] = (x[i] @ w + b)[:, 0]
            r, a = scores(held)
            lines.append(f"opening r {r:.3f}, amplitude {a:.2f}: {name} ridge {strength:g}")
    return lines


def voice_scores(
    corpus_dir: Path,
    voices: Sequence[str],
    strengths: Sequence[float],
    *,
    data: TrainingSet | None = None,
    clip_ids: Sequence[str] | None = None,
) -> dict[float, dict[str, tuple[float, np.ndarray]]]:
    """``--voice``: per ridge strength, the cross-validated R² (whole, per component) of the
    ``heard`` ridge fitted on his own recordings when the held-out clips are heard in his
    own voice (``own``) and in each Festival voice, beside the phones alone (``phones``).

    ``data`` and ``clip_ids`` are the corpus's training set and clip ids, when the caller
    has them already."""
    from miketalk.draw.trained.trajectory import HEARD_HALF, Context, window_features
    from miketalk.visemes import VisemeTable
    from miketalk_lab.bench.other_voice import voiced_recordings

    if data is None or clip_ids is None:
        from miketalk.draw.trained.mouths import measure_frames
        from miketalk.draw.trained.training import training_set

        frames = measure_frames(corpus_dir)
        data, clip_ids = training_set(corpus_dir, frames), frames.clip_ids
    table = VisemeTable()
    context = Context.of(data.phones, table)

    def features(recordings=None) -> list[np.ndarray]:
        heard = HEARD_HALF if recordings is not None else 0
        recordings = recordings if recordings is not None else [None] * len(data.phones)
        return [
            window_features(context, p, t, table, half=6, step=0.04, heard=heard, recording=r)
            for p, t, r in zip(data.phones, data.times, recordings, strict=True)
        ]

    phones_x, own_x = features(), features(data.recordings)
    voiced = {
        voice: features(
            voiced_recordings(corpus_dir, clip_ids, data.phones, voice=voice, table=table)
        )
        for voice in voices
    }
    out = {}
    for strength in strengths:
        fit = ridge_fit(strength)
        scores = {"phones": cross_validated_r2(phones_x, data.coords, fit)}
        scores["own"] = cross_validated_r2(own_x, data.coords, fit)
        for voice, xs in voiced.items():
            scores[voice] = cross_validated_r2(own_x, data.coords, fit, held_xs=xs)
        out[float(strength)] = scores
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    parser = bench_parser(__name__, __doc__, limit_help="(unused: every clip is used)")
    parser.add_argument("--corpus", type=Path, required=True, help="a face's corpus folder")
    parser.add_argument("--halves", type=int, nargs="+", default=[3, 6, 9, 12])
    parser.add_argument("--ridges", type=float, nargs="+", default=[30.0, 100.0, 300.0])
    parser.add_argument("--mlp", type=int, nargs="*", default=[], help="hidden layer sizes")
    parser.add_argument("--alpha", type=float, default=0.1, help="the MLP's L2 penalty")
    parser.add_argument("--heard", action="store_true", help="also hear each clip's recording")
    parser.add_argument(
        "--opening", action="store_true", help="predict dlib's lip opening itself (slow)"
    )
    parser.add_argument(
        "--voice",
        nargs="+",
        default=[],
        choices=("kal", "ked"),
        help="the heard trajectory fitted on his recordings, meeting each held-out clip "
        "spoken by this Festival voice at his own phone timing (miketalk_lab.bench.other_voice)",
    )

    def check(args) -> str | None:
        if not (args.corpus / "phones.tsv").is_file():
            return f"{args.corpus} is not a corpus folder (no phones.tsv)"
        return None

    def work(args) -> str:
        from miketalk.draw.trained.mouths import measure_frames
        from miketalk.draw.trained.training import training_set
        from miketalk.draw.trained.trajectory import (
            HEARD_HALF,
            Context,
            window_features,
        )
        from miketalk.visemes import VisemeTable

        frames = measure_frames(args.corpus)
        data = training_set(args.corpus, frames)
        table = VisemeTable()
        context = Context.of(data.phones, table)
        lines = [f"{len(data.phones)} clips, {len(frames.coords)} frames"]

        def features(half: int) -> list[np.ndarray]:
            return [
                window_features(context, p, t, table, half=half, step=0.04)
                for p, t in zip(data.phones, data.times, strict=True)
            ]

        def heard(half: int) -> list[np.ndarray]:
            return [
                window_features(
                    context, p, t, table, half=half, step=0.04, heard=HEARD_HALF, recording=r
                )
                for p, t, r in zip(data.phones, data.times, data.recordings, strict=True)
            ]

        def report(name: str, xs: list[np.ndarray], fit: Fit) -> None:
            t0 = time.perf_counter()
            whole, per = cross_validated_r2(xs, data.coords, fit)
            lines.append(
                f"{name}: R2 {whole:.4f}, first four {np.round(per[:4], 3).tolist()} "
                f"({time.perf_counter() - t0:.1f} s)"
            )

        for half in args.halves:
            xs = features(half)
            for strength in args.ridges:
                report(f"ridge half {half} strength {strength:g}", xs, ridge_fit(strength))
        if args.heard:
            xs = heard(6)
            for strength in args.ridges:
                report(f"heard ridge half 6 strength {strength:g}", xs, ridge_fit(strength))
        if args.voice:
            scores = voice_scores(
                args.corpus, args.voice, args.ridges, data=data, clip_ids=frames.clip_ids
            )
            for strength, by in scores.items():
                lines.append(
                    f"heard ridge {strength:g}, held-out clips heard in: "
                    + "; ".join(f"{k} R2 {w:.4f} (first {p[0]:.3f})" for k, (w, p) in by.items())
                )
        if args.opening:
            xs = {"phones": features(6)}
            xs["phones and recording"] = heard(6)
            lines += opening_ceiling(args.corpus, data, frames.clip_ids, xs, args.ridges)
        if args.mlp:
            xs = features(6)
            for hidden in args.mlp:
                report(f"mlp half 6 hidden {hidden}", xs, mlp_fit(hidden, args.alpha))
        return "\n".join(lines)

    return run_bench(parser, argv, work, check=check)


if __name__ == "__main__":
    raise SystemExit(main())
