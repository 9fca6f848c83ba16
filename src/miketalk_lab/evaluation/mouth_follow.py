"""How a dub's mouth follows the real one over many clips: its lips' colour and the pooled
lag of its opening (the held-out bench of people other than s1,
:mod:`miketalk_lab.bench.anyone`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd


def lip_colours(video: Path, points: np.ndarray) -> np.ndarray:
    """Per frame the mean CIELAB colour ``(N, 3)`` (L 0-100, a* and b* about 0) of the lips
    (inside the outer lip line, points 48-59, outside the inner one, 60-67)."""
    import cv2

    from miketalk.media.decode import iter_video_frames

    out = np.full((len(points), 3), np.nan)
    for k, frame in enumerate(iter_video_frames(video, frames=len(points))):
        outer, inner = points[k, 48:60].astype(np.int32), points[k, 60:68].astype(np.int32)
        x0, y0 = np.maximum(outer.min(axis=0) - 2, 0)
        x1, y1 = outer.max(axis=0) + 3
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.fillPoly(mask, [outer - (x0, y0)], 1)
        cv2.fillPoly(mask, [inner - (x0, y0)], 0)
        if mask.any():
            box = np.float32(frame[y0:y1, x0:x1]) / 255
            out[k] = cv2.cvtColor(box, cv2.COLOR_RGB2LAB)[mask > 0].mean(axis=0)
    return out


def pooled_shifts(frames: pd.DataFrame, shifts: range = range(-3, 4)) -> pd.DataFrame:
    """Per renderer the correlation of its opening with the real one over every held-out
    clip's speech at once (all clips' pairs in one r), the dub read ``shift`` frames later
    (a positive best shift: the dub runs late); one row per renderer, one column per shift."""
    names = [c for c in frames.columns if c not in ("clip", "frame", "real", "speech")]
    rows = {}
    for name in names:
        out = {}
        for shift in shifts:
            xs, ys = [], []
            for _, g in frames.groupby("clip", sort=False):
                dub, real = g[name].to_numpy(float), g["real"].to_numpy(float)
                k = np.flatnonzero(g["speech"].to_numpy(bool))
                k = k[(k + shift >= 0) & (k + shift < len(dub))]
                keep = np.isfinite(dub[k + shift])
                xs.append(dub[k + shift][keep])
                ys.append(real[k][keep])
            x, y = np.concatenate(xs), np.concatenate(ys)
            out[shift] = float(np.corrcoef(x, y)[0, 1]) if len(x) > 2 and x.std() > 0 else 0.0
        rows[name] = out
    return pd.DataFrame.from_dict(rows, orient="index")


def shifts_table(pooled: pd.DataFrame) -> str:
    """:func:`pooled_shifts` as Markdown, each renderer's best shift named."""
    lines = ["| renderer | " + " | ".join(f"{s:+d}" for s in pooled.columns) + " | best |",
             "|---|" + "---|" * (len(pooled.columns) + 1)]  # fmt: skip
    for name, row in pooled.iterrows():
        best = int(row.idxmax())
        cells = " | ".join(f"{v:.2f}" for v in row)
        lines.append(f"| {name} | {cells} | {best:+d} ({row[best]:.2f}) |")
    return "\n".join(lines) + "\n"
