"""Ground truth from the synthetic face: true flows between visemes, true in-between frames.

Only for a corpus recorded by :mod:`synth_face`: its ``frames.tsv`` holds the
mouth parameters of every frame, so the parameters of each viseme image are
known, the true flow between two visemes is the projected motion of the mesh,
and the ideal in-between image of a morph from A to B at alpha is the render at
``lerp(p_A, p_B, alpha)`` (the face is linear in its parameters).
"""

from __future__ import annotations

import os
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.flow import pair_path, write_flow_pair


def viseme_params(
    frames_tsv: str | os.PathLike[str], visemes: pd.DataFrame
) -> dict[str, np.ndarray]:
    """The mouth parameters of each viseme's frame, from the recording's frame table."""
    from synth_face import Face

    table = pd.read_csv(frames_tsv, sep="\t", keep_default_na=False)
    names = list(Face().param_names)
    missing = [n for n in names if n not in table.columns]
    if missing:
        raise MiketalkError(
            f"{frames_tsv} has no mouth parameters ({', '.join(missing)}): "
            "ground truth exists only for the synthetic face"
        )
    params = table[names].to_numpy(np.float64)
    return {v: params[int(f)] for v, f in zip(visemes["viseme"], visemes["frame"], strict=True)}


def write_true_flows(
    out_dir: str | os.PathLike[str], params: dict[str, np.ndarray], *, size: int
) -> np.ndarray:
    """Write the true flow database (with validity masks); return the mouth mask."""
    from synth_face import Face, FaceRenderer

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    renderer = FaceRenderer(Face(), size=size)
    try:
        for a, b in combinations(list(params), 2):
            forward, valid_f = renderer.true_flow(params[a], params[b])
            backward, valid_b = renderer.true_flow(params[b], params[a])
            write_flow_pair(
                pair_path(out, a, b),
                np.where(valid_f[..., None], forward, 0).astype(np.float32),
                np.where(valid_b[..., None], backward, 0).astype(np.float32),
                source=a,
                target=b,
                estimator="truth",
                settings={"size": size},
                valid=(valid_f, valid_b),
            )
        return renderer.mouth_mask()
    finally:
        renderer.close()
