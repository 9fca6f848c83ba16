"""Build the package's person-independent mouth model from every talker's corpus.

``python -m miketalk_lab.bench.pooled_mouth --corpus NAME=DIR [--corpus NAME=DIR ...]
--out FILE.npz [--check NAME=DIR ...]``

Each ``--corpus`` is a corpus folder kept by a face-crop build (``miketalk build
--keep-corpus``: the canonical crop's frames, the aligned phones, the sound) of one talker:
GRID's s1 (its training clips only), the other GRID talkers, never a clip a bench holds
out. Every frame's mouth geometry is measured
(:func:`miketalk.draw.trained.pooled.frame_geometry`: the lips' parting, the mouth's width
and the jaw, by optical flow from the clip's median mouth, in crop pixels); a ridge
regression from the viseme window, the pauses and the heard recording to it is fitted on
every clip of every talker, once per :data:`VARIANTS` (features and strength), each
scored leave-one-talker-out on the talkers after the first. Writes
``FILE.npz`` (what :func:`~miketalk.draw.trained.pooled.read_pooled` reads) and its
provenance beside it (``pooled_mouth.json``: the corpora, their clips and
frames, the cross-validation, the commit).

``--check`` corpora (e.g. a weekly-address fold's training clips) are not fitted on: for
each, the adaptation of the product (:func:`~miketalk.draw.trained.pooled.fit_pooled`):
its cross-validated R² over his clips, and the lag and the variant it chose.
"""

from __future__ import annotations

import argparse
import json
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from miketalk.draw.trained.pooled import (
    GEOMETRY,
    PROVENANCE,
    PooledModel,
    fit_pooled,
    frame_geometry,
    read_pooled,
)
from miketalk.draw.trained.ridge import ridge
from miketalk.draw.trained.trajectory import HEARD_HALF, HEARD_STEP
from miketalk.visemes import VisemeTable

ROOT = Path(__file__).resolve().parents[3]
#: The viseme window: half-width (steps) and step (s), as the trained face's.
HALF, STEP = 6, 0.04
#: The regressions shipped, each fitted to every talker: the features (``all``: the
#: viseme window, the pauses and the heard recording; ``visemes``: without the recording)
#: and the ridge strength. A face's adaptation chooses one by cross-validation over its
#: own clips (:func:`~miketalk.draw.trained.pooled.fit_pooled`): leave-one-talker-out on
#: the GRID talkers, the viseme window alone at 1000 transfers best (opening r 0.56); on
#: the weekly addresses' training clips, the heard recording under a strong ridge (0.62).
VARIANTS = (
    ("all", 100.0), ("all", 300.0), ("all", 1000.0), ("all", 3000.0), ("all", 10000.0),
    ("visemes", 300.0), ("visemes", 1000.0),
)  # fmt: skip


def talker(corpus: Path):
    """A corpus's frames (:class:`~miketalk.draw.trained.mouths.MouthFrames`), its training
    set and its frames' geometry."""
    from miketalk.draw.trained.mouths import measure_frames
    from miketalk.draw.trained.training import training_set

    frames = measure_frames(corpus, components=4)
    return frames, training_set(corpus, frames), frame_geometry(frames)


def features(model: PooledModel, data, table: VisemeTable) -> list[np.ndarray]:
    """Each clip's regression inputs."""
    return [
        model.features(p, t, table, r)
        for p, t, r in zip(data.phones, data.times, data.recordings, strict=True)
    ]


def _clip_r(real: np.ndarray, predicted: np.ndarray, clips: np.ndarray, shift: int = 0):
    """Per dimension, r over all frames, each clip less its mean, ``real`` read ``shift``
    frames later."""
    a, b = [], []
    for c in np.unique(clips):
        x, y = real[clips == c], predicted[clips == c]
        x, y = (x[shift:], y[: len(y) - shift]) if shift else (x, y)
        a.append(x - x.mean(axis=0))
        b.append(y - y.mean(axis=0))
    a, b = np.concatenate(a), np.concatenate(b)
    return [round(float(np.corrcoef(a[:, k], b[:, k])[0, 1]), 4) for k in range(a.shape[1])]


def build(corpora: dict[str, Path], out: Path, *, checks: dict[str, Path]) -> dict:
    """Fit the pooled model (see the module docstring); its provenance."""
    table = VisemeTable()
    talkers = {name: talker(path) for name, path in corpora.items()}
    k = len(GEOMETRY)
    probe = PooledModel(
        tuple(table.visemes), HALF, STEP, HEARD_HALF, HEARD_STEP, np.zeros((1, 1, k)),
        np.zeros((1, k)), ("probe",), "",
    )  # fmt: skip
    xs = {name: np.concatenate(features(probe, t[1], table)) for name, t in talkers.items()}
    n_visemes = (2 * HALF + 1) * len(table.visemes) + 18  # the viseme window and the pauses
    columns = {"all": slice(None), "visemes": slice(0, n_visemes)}
    weights, intercepts, loto = [], [], {}
    for kind, strength in VARIANTS:
        name = f"{kind}:{strength:g}"
        cols = columns[kind]

        def fit(names, cols=cols, strength=strength):
            x = np.concatenate([xs[n] for n in names])
            w = np.zeros((x.shape[1], k))
            w[cols], b = ridge(x[:, cols], np.concatenate([talkers[n][2] for n in names]), strength)
            return w, b

        w, b = fit(list(talkers))
        weights.append(w)
        intercepts.append(b)
        loto[name] = {}  # each talker but the first predicted by a fit without him
        for held in list(talkers)[1:]:
            w_, b_ = fit([n for n in talkers if n != held])
            frames, _, geometry = talkers[held]
            loto[name][held] = _clip_r(geometry, xs[held] @ w_ + b_, frames.clip)[0]
    settings = {
        "visemes": list(table.visemes), "half": HALF, "step": STEP, "heard": HEARD_HALF,
        "heard_step": HEARD_STEP, "geometry": list(GEOMETRY), "variants": list(loto),
    }  # fmt: skip
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "wb") as f:
        np.savez(
            f, weights=np.stack(weights), intercept=np.stack(intercepts),
            settings=np.array(json.dumps(settings)),
        )  # fmt: skip
    model = read_pooled(out)
    doc = {
        "what": "miketalk's person-independent mouth model (miketalk.draw.trained.pooled)",
        "built_by": "python -m miketalk_lab.bench.pooled_mouth "
        + " ".join(f"--corpus {k}=..." for k in corpora),
        "commit": _commit(),
        "corpora": {
            name: {
                "clips": list(t[0].clip_ids),
                "frames": len(t[2]),
                "seconds": round(len(t[2]) / t[0].fps, 2),
                "fps": t[0].fps,
            }
            for name, t in talkers.items()
        },
        "geometry": list(GEOMETRY),
        "variants": list(loto),
        "leave_talker_out_opening_r": {
            name: {"mean": round(float(np.mean(list(r.values()))), 4), **r}
            for name, r in loto.items()
        },
        "digest": model.digest,
        "checks": {name: check(model, path, table) for name, path in checks.items()},
    }
    (out.parent / PROVENANCE).write_text(json.dumps(doc, indent=1) + "\n", "utf-8")
    return doc


def check(model: PooledModel, corpus: Path, table: VisemeTable) -> dict:
    """A talker not fitted on: the pooled model's adaptation to him (cross-validated over
    his clips)."""
    _, data, geometry = talker(corpus)
    _, report = fit_pooled(data, table, geometry, pooled=model)
    return {
        "frames": len(geometry),
        "adapted_cv_r2": report["cv_r2"],
        "adapted_lag_frames": report["lag"],
        "adapted_variant": report["variant"],
    }


def _commit() -> str:
    """The project's commit (and ``+`` when its tree differs)."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()  # fmt: skip
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "src"],
                               capture_output=True, text=True).stdout.strip()  # fmt: skip
        return head + ("+" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _pairs(values: Sequence[str]) -> dict[str, Path]:
    out = {}
    for v in values or ():
        name, _, path = v.partition("=")
        out[name] = Path(path)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", action="append", required=True, help="NAME=DIR")
    parser.add_argument("--check", action="append", help="NAME=DIR, not fitted on")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    doc = build(_pairs(args.corpus), args.out, checks=_pairs(args.check))
    print(json.dumps({k: doc[k] for k in ("leave_talker_out_opening_r", "checks")}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
