"""The workflow's figures, drawn from its tidy tables with matplotlib (PNG, deterministic).

Each figure is a function ``name(..., out, ...)`` taking its inputs and
settings by keyword; :data:`FIGURES` names them and :func:`draw` draws one by
name (the workflow's ``figure_*`` rules).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from itertools import pairwise

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_path

Path_ = str | os.PathLike[str]


def _save(fig: plt.Figure, path: Path_) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, metadata={"Software": None}, bbox_inches="tight")
    plt.close(fig)


def epe_vs_levels(flow_epe_csv: Path_, out: Path_) -> None:
    """Mean EPE (direct flows, mouth and valid regions) against pyramid depth, per estimator."""
    table = pd.read_csv(flow_epe_csv)
    swept = table[(table["strategy"] == "direct") & table["method"].str.contains("-L")]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=False)
    for ax, region in zip(axes, ("mouth", "valid"), strict=True):
        part = swept[swept["region"] == region]
        for estimator, rows in part.groupby("estimator"):
            mean = rows.groupby("levels")["mean_epe"].mean()
            ax.plot(mean.index, mean.values, marker="o", label=estimator)
        ax.set_xlabel("pyramid levels")
        ax.set_ylabel("mean endpoint error (px)")
        ax.set_title(f"direct flows, {region} region")
        ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend()
    _save(fig, out)


def morph_psnr_vs_alpha(morph_csv: Path_, out: Path_) -> None:
    """Morph PSNR against alpha: true flow, estimated flow, cross-dissolve (mouth and full)."""
    table = pd.read_csv(morph_csv)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, region in zip(axes, ("mouth", "full"), strict=True):
        part = table[table["region"] == region]
        for candidate, rows in part.groupby("candidate"):
            mean = rows.groupby("alpha")["psnr"].mean()
            ax.plot(mean.index, mean.values, marker="o", label=candidate.replace("_", " "))
        ax.set_xlabel("alpha")
        ax.set_ylabel("PSNR vs true render (dB)")
        ax.set_title(f"{region} region, mean over viseme pairs")
        ax.grid(True, alpha=0.3)
        ax.legend()
    _save(fig, out)


def sync_vs_max_px(summary_csv: Path_, out: Path_) -> None:
    """Sync error and largest per-frame motion against max_px_per_frame, per frame rate."""
    table = pd.read_csv(summary_csv)
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    for fps, rows in table.groupby("fps"):
        rows = rows.sort_values("max_px_per_frame")
        x = rows["max_px_per_frame"]
        axes[0].plot(x, rows["largest_step_px_oversampled"], marker="o", label=f"{fps:g} fps")
        axes[0].plot(x, rows["largest_step_px_plain"], ls="--", alpha=0.6)
        axes[1].plot(x, rows["max_abs_viseme_offset_frames"], marker="o", label=f"{fps:g} fps")
        axes[2].plot(x, rows["lengthened_seconds"], marker="o", label=f"{fps:g} fps")
    lim = np.array([table["max_px_per_frame"].min(), table["max_px_per_frame"].max()])
    axes[0].plot(lim, lim, color="grey", lw=0.8, label="bound")
    axes[0].set_ylabel("largest per-frame motion (px)\n(dashed: no oversampling)")
    axes[1].set_ylabel("largest |viseme offset| (frames)")
    axes[2].set_ylabel("audio lengthened (s)")
    for ax in axes:
        ax.set_xlabel("max_px_per_frame")
        ax.grid(True, alpha=0.3)
        ax.legend()
    _save(fig, out)


def lipsync_diagram(
    model_dir: Path_, word: str, out: Path_, *, fps: float, max_px: float | None
) -> None:
    """The paper's Figure 8 for one word: diphones, viseme transitions, frames and alphas."""
    from miketalk.speech import get_backend
    from miketalk.talk.lipsync import speak_in_sync
    from miketalk.talk.say import open_model
    from miketalk.visemes import default_table

    festival = get_backend()
    model = open_model(model_dir)
    with festival.start(word) as speech:
        utterance, timeline = speak_in_sync(
            speech, default_table(), fps=fps,
            displacement=model.displacement, max_px_per_frame=max_px, sampling="paper",
        )  # fmt: skip
    fig, ax = plt.subplots(figsize=(11, 3.4))
    phones = utterance.phones
    for p in phones:
        ax.axvline(p.start, ymin=0.7, ymax=1.0, color="k", lw=0.6)
        ax.text(p.middle, 2.75, p.name, ha="center", va="center")
    for a, b in pairwise(phones):
        ax.annotate("", (b.middle, 2.45), (a.middle, 2.45), arrowprops={"arrowstyle": "<->"})
        ax.text(0.5 * (a.middle + b.middle), 2.25, f"{a.name}-{b.name}", ha="center", fontsize=7)
    for i, t in enumerate(timeline.transitions):
        color = "C0" if i % 2 else "C1"
        ax.barh(1.5, t.duration, left=t.start, height=0.4, color=color, alpha=0.5)
        ax.text(t.start + t.duration / 2, 1.5, f"{t.source}→{t.target}", ha="center", fontsize=7)
    for f in timeline.frames:
        ax.plot([f.time, f.time], [0.35, 0.75], color="k", lw=0.7)
        ax.text(f.time, 0.15, f"{f.alpha:.2f}", ha="center", fontsize=5, rotation=90)
    ax.set_yticks([0.5, 1.5, 2.6], ["frames (alpha)", "viseme transitions", "phones / diphones"])
    ax.set_xlabel("time (s)")
    ax.set_ylim(-0.2, 3.0)
    ax.set_xlim(0, utterance.duration)
    ax.set_title(f'lip-sync of "{word}" at {fps:g} fps (paper Fig. 8)')
    _save(fig, out)


def morph_strip(
    model_dir: Path_, pair: list[str], alphas: list[float], out: Path_, *, morph: dict
) -> None:
    """The paper's Figure 7: forward warps of each side, blend, after filling and median."""
    from miketalk.figures.sheets import grid
    from miketalk.media.images import write_png
    from miketalk.talk.say import open_model

    model = open_model(model_dir, morph_options=morph)
    a, b = pair
    morpher = model.morpher(a, b)
    images, labels = [], []
    for stage in ("warp0", "warp1", "blend", "filled", "final"):
        for alpha in alphas:
            images.append(getattr(morpher.stages(alpha), stage))
            labels.append(f"{stage} a={alpha:g}")
    write_png(out, grid(images, labels, cols=len(alphas)))


#: Every figure by name: ``draw(name, out, **inputs)`` calls ``FIGURES[name](out=out, **inputs)``.
FIGURES: dict[str, Callable[..., None]] = {
    "epe_vs_levels": epe_vs_levels,
    "morph_psnr_vs_alpha": morph_psnr_vs_alpha,
    "sync_vs_max_px": sync_vs_max_px,
    "lipsync_diagram": lipsync_diagram,
    "morph_strip": morph_strip,
}


def draw(figure: str, out: Path_, **inputs: object) -> None:
    """Draw the figure named ``figure`` (a key of :data:`FIGURES`) to ``out``.

    Parameters
    ----------
    figure : str
        The figure's name.
    out : path-like
        The PNG to write.
    **inputs
        The figure function's other arguments, by keyword (input files and
        settings).

    Raises
    ------
    MiketalkError
        For an unknown figure name.
    """
    if figure not in FIGURES:
        raise MiketalkError(f"no figure {figure!r}; known: {', '.join(sorted(FIGURES))}")
    FIGURES[figure](out=out, **inputs)
