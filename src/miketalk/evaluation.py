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
from miketalk.flow import FlowDatabase, endpoint_error


def read_mask(path: str | os.PathLike[str]) -> np.ndarray:
    """A mask PNG (non-zero = inside) as (H, W) bool."""
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise MiketalkError(f"cannot read mask {path}")
    return image > 127


def visemes_of_database(directory: str | os.PathLike[str]) -> list[str]:
    """The viseme names recorded in a flow database's file headers."""
    from miketalk.flow import read_flow_pair

    names: dict[str, None] = {}
    for path in sorted(Path(directory).glob("*.exr")):
        pair = read_flow_pair(path)
        names[pair.source] = None
        names[pair.target] = None
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
                    **endpoint_error(flow, true, mask),
                }
            )
    return pd.DataFrame(rows)
