"""The in-between table summarized: each method against the cross-dissolve, as table and text."""

from __future__ import annotations

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk_lab.evaluation.inbetween import _DISSOLVE, COLUMNS


def summarize_inbetween(table: pd.DataFrame, *, baseline: str = _DISSOLVE) -> pd.DataFrame:
    """Mean and spread over clips of each method's per-clip mean, by ``k``.

    Each clip counts once: its PSNR and SSIM are first averaged over its
    frames, then the clips' means are averaged. The gain over ``baseline`` is
    paired: per clip, the method's mean minus the baseline's.

    Parameters
    ----------
    table : pandas.DataFrame
        Rows of :func:`inbetween_table` (any number of clips).
    baseline : str, keyword-only
        The method gains are measured against (the dissolve).

    Returns
    -------
    pandas.DataFrame
        One row per (k, method), in the table's method order, with columns
        ``k``, ``method``, ``clips``, ``frames``, ``psnr_mean``, ``psnr_sd``,
        ``ssim_mean``, ``ssim_sd`` (sd: standard deviation over clips, 0 for
        one clip), ``gain_mean``, ``gain_sd`` (dB over ``baseline``) and
        ``clips_better`` (clips where the method's mean PSNR beats the
        baseline's; NaN columns when the baseline is not in the table).

    Raises
    ------
    MiketalkError
        If the table lacks a column of :data:`COLUMNS` or is empty.
    """
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise MiketalkError(f"the table lacks column(s) {missing}")
    if table.empty:
        raise MiketalkError("the table is empty")
    order = list(dict.fromkeys(table["method"]))
    per_clip = (
        table.groupby(["k", "method", "clip"], sort=False)
        .agg(psnr=("psnr_mouth", "mean"), ssim=("ssim_mouth", "mean"), frames=("t", "size"))
        .reset_index()
    )
    base = per_clip[per_clip["method"] == baseline].set_index(["k", "clip"])["psnr"]
    per_clip["gain"] = per_clip["psnr"].to_numpy() - base.reindex(
        pd.MultiIndex.from_frame(per_clip[["k", "clip"]])
    ).to_numpy(dtype=float)
    rows = []
    for (k, method), group in per_clip.groupby(["k", "method"], sort=False):
        sd = 1 if len(group) > 1 else 0
        gain = group["gain"]
        rows.append(
            {
                "k": int(k),
                "method": method,
                "clips": len(group),
                "frames": int(group["frames"].sum()),
                "psnr_mean": group["psnr"].mean(),
                "psnr_sd": group["psnr"].std(ddof=sd),
                "ssim_mean": group["ssim"].mean(),
                "ssim_sd": group["ssim"].std(ddof=sd),
                "gain_mean": gain.mean(),
                "gain_sd": gain.std(ddof=sd),
                "clips_better": int((gain > 0).sum()) if gain.notna().all() else np.nan,
            }
        )
    summary = pd.DataFrame(rows)
    summary["_order"] = summary["method"].map({m: i for i, m in enumerate(order)})
    summary = summary.sort_values(["k", "_order"]).drop(columns="_order")
    return summary.reset_index(drop=True)


def summary_markdown(summary: pd.DataFrame, *, baseline: str = _DISSOLVE) -> str:
    """The summary as two markdown tables (PSNR with the gain over ``baseline``, and SSIM).

    Rows are methods, columns the ``k``; a cell reads ``mean ± sd`` over clips,
    the PSNR cells followed by the paired gain over ``baseline`` and how many
    clips beat it.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`summarize_inbetween`'s result.
    baseline : str, keyword-only
        The baseline's name (its own gain is not shown).

    Returns
    -------
    str
        Markdown, ending with a newline.
    """
    ks = sorted(summary["k"].unique())
    methods = list(dict.fromkeys(summary["method"]))
    cells = summary.set_index(["method", "k"])
    clips = int(summary["clips"].max())
    head = "| method | " + " | ".join(f"k = {k}" for k in ks) + " |"
    rule = "| --- |" + " --- |" * len(ks)
    psnr_lines = [
        f"Mouth-region PSNR (dB), mean ± sd over {clips} clips; in brackets the paired gain "
        f"over {baseline} (mean ± sd) and the clips where it is positive.",
        "",
        head,
        rule,
    ]
    ssim_lines = [f"Mouth-region SSIM, mean ± sd over {clips} clips.", "", head, rule]
    for method in methods:
        p_cells, s_cells = [], []
        for k in ks:
            if (method, k) not in cells.index:
                p_cells.append("")
                s_cells.append("")
                continue
            row = cells.loc[(method, k)]
            text = f"{row['psnr_mean']:.2f} ± {row['psnr_sd']:.2f}"
            if method != baseline and pd.notna(row["gain_mean"]):
                text += (
                    f" ({row['gain_mean']:+.2f} ± {row['gain_sd']:.2f}, "
                    f"{int(row['clips_better'])}/{int(row['clips'])})"
                )
            p_cells.append(text)
            s_cells.append(f"{row['ssim_mean']:.4f} ± {row['ssim_sd']:.4f}")
        psnr_lines.append(f"| {method} | " + " | ".join(p_cells) + " |")
        ssim_lines.append(f"| {method} | " + " | ".join(s_cells) + " |")
    return "\n".join(psnr_lines) + "\n\n" + "\n".join(ssim_lines) + "\n"
