"""Measurements against the synthetic face's ground truth, as tidy tables.

flow_epe_table
    endpoint error of a flow database against the true flows, per ordered
    viseme pair, over the valid mask and over the mouth region.
morph_fidelity_table
    morphs with true flow, with estimated flow, and a cross-dissolve, each
    against the true in-between render (PSNR and SSIM, mouth and full frame).
"""

from __future__ import annotations

import json
import os
from itertools import permutations
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase
from miketalk_lab.evaluation.flow_error import endpoint_error_map, summarize_endpoint_error


def read_mask(path: str | os.PathLike[str]) -> np.ndarray:
    """A mask PNG (non-zero = inside) as (H, W) bool."""
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise MiketalkError(f"cannot read mask {path}")
    return image > 127


def visemes_of_database(directory: str | os.PathLike[str]) -> list[str]:
    """The viseme names recorded in a flow database's file headers."""
    from miketalk.flow import read_flow_header

    names: dict[str, None] = {}
    for path in sorted(Path(directory).glob("*.exr")):
        header = read_flow_header(path)  # the pixels are not needed
        names[header["source"]] = None
        names[header["target"]] = None
    if not names:
        raise MiketalkError(f"flow database {directory} has no pair files")
    return list(names)


def flow_epe_table(
    flows_dir: str | os.PathLike[str],
    truth_dir: str | os.PathLike[str],
    mouth_mask: str | os.PathLike[str],
    *,
    method: str,
    estimator: str,
    settings: dict,
    strategy: str,
) -> pd.DataFrame:
    """Endpoint error of every ordered pair, in the valid and mouth regions.

    Returns
    -------
    DataFrame
        One row per pair x region: method, estimator, levels, settings,
        strategy, source, target, region, mean_epe, pct_over_1px,
        pct_over_3px, pixels.
    """
    estimated, truth = FlowDatabase(flows_dir), FlowDatabase(truth_dir)
    mouth = read_mask(mouth_mask)
    rows = []
    for a, b in permutations(visemes_of_database(truth_dir), 2):
        flow, true, valid = estimated.flow(a, b), truth.flow(a, b), truth.valid(a, b)
        if valid is None:
            raise MiketalkError(f"true flow file for {a!r}, {b!r} has no validity mask")
        error = endpoint_error_map(flow, true)
        for region, mask in (("valid", valid), ("mouth", valid & mouth)):
            rows.append(
                {
                    "method": method,
                    "estimator": estimator,
                    "levels": settings.get("levels", np.nan),
                    "settings": json.dumps(settings, sort_keys=True),
                    "strategy": strategy,
                    "source": a,
                    "target": b,
                    "region": region,
                    **summarize_endpoint_error(error, mask),
                }
            )
    return pd.DataFrame(rows)


def morph_fidelity_table(
    *,
    visemes: pd.DataFrame,
    images_dir: str | os.PathLike[str],
    flows_dir: str | os.PathLike[str],
    truth_dir: str | os.PathLike[str],
    frames_tsv: str | os.PathLike[str],
    mouth_mask: str | os.PathLike[str],
    alphas: list[float],
    morph_options: dict | None = None,
) -> pd.DataFrame:
    """Morph fidelity against the true in-between render, per ordered pair and alpha.

    For each ordered viseme pair (A, B) and alpha, three candidates are scored
    against the render at ``lerp(p_A, p_B, alpha)``: the morph with the true
    flow (the error of the morph itself), the morph with the estimated flow
    (the whole pipeline), and a plain cross-dissolve (what the paper set out
    to beat). Rows: source, target, alpha, candidate, region, psnr, ssim,
    holes_before_fill (pixels neither warp reached), holes_left.
    """
    from miketalk.media.images import read_image
    from miketalk.render.morph import Morpher, cross_dissolve
    from miketalk.render.splat import HOLE_VALUE
    from miketalk_lab.evaluation.measures import psnr, ssim
    from miketalk_lab.evaluation.truth import viseme_params
    from synth_face import Face, FaceRenderer

    options = dict(morph_options or {})
    estimated, truth = FlowDatabase(flows_dir), FlowDatabase(truth_dir)
    mouth = read_mask(mouth_mask)
    params = viseme_params(frames_tsv, visemes)
    images = {
        v: read_image(Path(images_dir) / name)
        for v, name in zip(visemes["viseme"], visemes["image"], strict=True)
    }
    size = next(iter(images.values())).shape[0]
    renderer = FaceRenderer(Face(), size=size)
    references: dict[bytes, np.ndarray] = {}  # (a, b, alpha) and (b, a, 1 - alpha) are one pose
    rows = []
    try:
        for a, b in permutations(list(images), 2):
            morphers = {
                "morph_true_flow": Morpher(
                    images[a], images[b], truth.flow(a, b), truth.flow(b, a), **options
                ),
                "morph_estimated_flow": Morpher(
                    images[a], images[b], estimated.flow(a, b), estimated.flow(b, a), **options
                ),
            }
            for alpha in alphas:
                pose = (1 - alpha) * params[a] + alpha * params[b]
                key = pose.tobytes()
                if key not in references:
                    references[key] = renderer.render(pose)
                reference = references[key]
                candidates = {"cross_dissolve": (cross_dissolve(images[a], images[b], alpha), 0, 0)}
                for name, morpher in morphers.items():
                    frame, hole = morpher.frame_and_holes(alpha)
                    left = int(np.all(frame[hole] == HOLE_VALUE, axis=-1).sum())
                    candidates[name] = (frame, int(hole.sum()), left)
                for name, (image, holes, left) in candidates.items():
                    for region, mask in (("mouth", mouth), ("full", None)):
                        rows.append(
                            {
                                "source": a,
                                "target": b,
                                "alpha": alpha,
                                "candidate": name,
                                "region": region,
                                "psnr": psnr(image, reference, mask),
                                "ssim": ssim(image, reference, mask),
                                "holes_before_fill": holes,
                                "holes_left": left,
                            }
                        )
    finally:
        renderer.close()
    return pd.DataFrame(rows)
