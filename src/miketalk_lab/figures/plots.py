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


#: A colour per sampling mode, the same in every figure.
MODE_COLOURS = {"blur": "C0", "paper": "C1", "none": "C2"}


def _modes(table: pd.DataFrame) -> list[str]:
    """The sampling modes of a sync summary, blur, paper, none first."""
    known = list(MODE_COLOURS)
    return sorted(
        table["sampling"].unique(), key=lambda m: (known.index(m) if m in known else len(known), m)
    )


def sync_vs_max_px(summary_csv: Path_, out: Path_) -> None:
    """Sync against max_px_per_frame: a row per sampling mode, a line per frame rate.

    Columns: the largest step between consecutive morphs (dashed: one morph
    per frame, at the speech's own timing), the largest viseme offset, and the
    seconds the speech was lengthened.
    """
    table = pd.read_csv(summary_csv)
    modes = _modes(table)
    fig, axes = plt.subplots(
        len(modes), 3, figsize=(12, 3.3 * len(modes)), squeeze=False, sharex=True,
        sharey="col", layout="constrained",
    )  # fmt: skip
    lim = np.array([table["max_px_per_frame"].min(), table["max_px_per_frame"].max()])
    colours = {fps: f"C{i}" for i, fps in enumerate(sorted(table["fps"].unique()))}
    for row, mode in zip(axes, modes, strict=True):
        for fps, rows in table[table["sampling"] == mode].groupby("fps"):
            rows = rows.sort_values("max_px_per_frame")
            x, style = rows["max_px_per_frame"], {"color": colours[fps]}
            row[0].plot(x, rows["largest_step_px_oversampled"], marker="o", label=f"{fps:g} fps",
                        **style)  # fmt: skip
            row[0].plot(x, rows["largest_step_px_plain"], ls="--", alpha=0.6, **style)
            row[1].plot(x, rows["max_abs_viseme_offset_frames"], marker="o", **style)
            row[2].plot(x, rows["lengthened_seconds"], marker="o", **style)
        row[0].plot(lim, lim, color="grey", lw=0.8, label="bound")
        row[0].set_ylabel("largest step between morphs (px)\n(dashed: one morph per frame)")
        row[1].set_ylabel("largest |viseme offset| (frames)")
        row[2].set_ylabel("speech lengthened (s)")
        for ax in row:
            ax.set_title(f"sampling {mode}", fontsize=10)
            ax.grid(True, alpha=0.3)
        row[0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("max_px_per_frame")
    _save(fig, out)


def sampling_vs_max_px(summary_csv: Path_, out: Path_, *, fps: float) -> None:
    """The sampling modes against max_px_per_frame at one frame rate.

    Four panels, a line per mode: the duration of the speech over its natural
    duration (target of the default: at most 1.1), the largest step between
    consecutive morphs, the largest motion from one frame to the next, and the
    mean jerk of the frames (smoothness; lower is smoother).

    Parameters
    ----------
    summary_csv : path-like
        A sync summary (:func:`miketalk_lab.evaluation.sync.summarize_sync`) with
        rows of several modes.
    out : path-like
        The PNG to write.
    fps : float
        The frame rate whose rows are drawn.
    """
    table = pd.read_csv(summary_csv)
    table = table[np.isclose(table["fps"], fps)]
    if table.empty:
        raise MiketalkError(f"{summary_csv} has no rows at {fps:g} fps")
    panels = (
        ("duration_ratio", "speech duration / natural duration"),
        ("largest_step_px_oversampled", "largest step between morphs (px)"),
        ("largest_frame_motion_px", "largest motion frame to frame (px)"),
        ("mean_jerk", "mean jerk of the frames (grey levels)"),
    )
    fig, axes = plt.subplots(1, len(panels), figsize=(15, 3.8), layout="constrained")
    for mode in _modes(table):
        rows = table[table["sampling"] == mode].sort_values("max_px_per_frame")
        for ax, (column, _) in zip(axes, panels, strict=True):
            # the first mode's larger markers show where the modes' points coincide
            ax.plot(rows["max_px_per_frame"], rows[column], marker="o", label=mode,
                    color=MODE_COLOURS.get(mode), markersize=9 if mode == "blur" else 5,
                    lw=2.5 if mode == "blur" else 1.5)  # fmt: skip
    plain = table.sort_values("max_px_per_frame").drop_duplicates("max_px_per_frame")
    axes[1].plot(plain["max_px_per_frame"], plain["largest_step_px_plain"], ls="--",
                 color="grey", label="one morph per frame")  # fmt: skip
    lim = np.array([table["max_px_per_frame"].min(), table["max_px_per_frame"].max()])
    axes[1].plot(lim, lim, color="k", lw=0.8, label="bound")
    axes[0].axhline(1.1, color="grey", ls=":", lw=1, label="target of the default")
    axes[0].set_ylim(bottom=0)
    for ax, (_, label) in zip(axes, panels, strict=True):
        ax.set_xlabel("max_px_per_frame")
        ax.set_title(label, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    sentences = ", ".join(sorted(table["sentence"].unique()))
    fig.suptitle(f"sampling modes on {sentences} at {fps:g} fps")
    _save(fig, out)


def lipsync_diagram(
    model_dir: Path_, word: str, out: Path_, *, fps: float, max_px: float | None
) -> None:
    """The paper's Figure 8 for one word: diphones, viseme transitions, frames and alphas."""
    from miketalk.lipsync.sampling import speak_in_sync
    from miketalk.speech import get_backend
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
    from miketalk.media.images import write_png
    from miketalk.media.sheets import grid
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


def sampling_strip(
    model_dir: Path_, timelines: list[Path_], out: Path_, *, morph: dict, columns: int = 8
) -> None:
    """Frames of one sentence in several sampling modes at the same moments of the speech.

    A row per timeline JSON (:func:`miketalk.talk.utterance.read_said`), a column per
    moment: ``columns`` consecutive frame times of the speech at its natural
    timing, about its fastest transition. The timeline nearest natural speed
    (blur) shows exactly those frames; a lengthened one (paper) shows its frame
    nearest the same moment of the speech (phone boundaries mapped linearly),
    so its frame numbers run further apart. The frames are rendered from the
    timelines as ``say`` renders them and cropped to where they differ most.

    Parameters
    ----------
    model_dir : path-like
        The model that said them.
    timelines : list of path-like
        The utterances' JSON files, one per row: the same sentence.
    out : path-like
        The PNG to write.
    morph : dict
        The model's morph options (as the utterances were made with).
    columns : int
        Frames per row.

    Raises
    ------
    MiketalkError
        If the timelines do not say the same phones.
    """
    from miketalk.lipsync.timeline import frame_count
    from miketalk.media.images import write_png
    from miketalk.media.sheets import grid
    from miketalk.talk.say import open_model
    from miketalk.talk.utterance import read_said

    model = open_model(model_dir, morph_options=morph)
    saids = [read_said(p) for p in timelines]
    if any(s.lipsync_model != "paper" for s in saids):
        raise MiketalkError("the sampling strip draws utterances of the paper's lip-sync model")
    names = [[p.name for p in s.planned_phones] for s in saids]
    if any(
        n != names[0] or len(s.timeline.phones) != len(n) for s, n in zip(saids, names, strict=True)
    ):
        raise MiketalkError("the sampling strip's timelines do not say the same phones")

    def bounds(phones: tuple) -> np.ndarray:
        return np.array([0.0, *(p.end for p in phones)])

    def spoken(said: object, t: float) -> float:  # natural time -> the utterance's time
        return float(np.interp(t, bounds(said.planned_phones), bounds(said.timeline.phones)))

    reference = min(saids, key=lambda s: s.timeline.duration / s.planned_duration)
    fps = reference.timeline.fps
    ref = reference.timeline
    fastest = max(
        (t for t in ref.transitions if t.duration > 0),
        key=lambda t: model.displacement(t.source, t.target) / t.duration,
    )
    middle = float(np.interp(fastest.start + fastest.duration / 2, bounds(ref.phones),
                             bounds(reference.planned_phones)))  # fmt: skip
    n = frame_count(reference.planned_duration, fps)
    first = int(np.clip(round(middle * fps) - columns // 2, 0, max(0, n - columns)))
    moments = [(first + j) / fps for j in range(min(columns, n))]
    images, labels = [], []
    for said in saids:
        timeline = said.timeline
        for j, t in enumerate(moments):
            k = int(np.clip(round(spoken(said, t) * timeline.fps), 0, len(timeline.frames) - 1))
            images.append(model.draw(timeline, timeline.frames[k]))
            ratio = timeline.duration / said.planned_duration
            head = f"{said.sampling} x{ratio:.2f} " if j == 0 else f"{said.sampling} "
            labels.append(f"{head}#{k} {k / timeline.fps:.2f}s")
    # crop to where the frames differ most (the lips), grown to a 5:3 box about them
    stack = np.stack(images).astype(np.int16)
    change = np.abs(stack - stack[:1]).max(axis=(0, 3))
    ys, xs = (change >= max(12, change.max() // 2)).nonzero()
    if len(ys):
        h, w = change.shape
        width = min(w, xs.max() - xs.min() + 1 + 24)
        height = min(h, max(ys.max() - ys.min() + 1 + 24, round(0.6 * width)))
        y0 = int(np.clip((ys.min() + ys.max() + 1 - height) // 2, 0, h - height))
        x0 = int(np.clip((xs.min() + xs.max() + 1 - width) // 2, 0, w - width))
        images = [im[y0 : y0 + height, x0 : x0 + width] for im in images]
    scale = max(1.0, 200.0 / images[0].shape[1])
    write_png(out, grid(images, labels, cols=len(moments), scale=scale))


#: Every figure by name: ``draw(name, out, **inputs)`` calls ``FIGURES[name](out=out, **inputs)``.
def heldout_trajectory(
    frames_csv: Path_, phones_json: Path_, out: Path_, *, clip: str, model: str
) -> None:
    """The first eigenlip coefficient over one held-out clip, real vs synthesized, phones marked."""
    import json

    table = pd.read_csv(frames_csv)
    part = table[(table["clip"] == clip) & (table["model"] == model)]
    morph = part[part["renderer"] == "morph"]
    fig, ax = plt.subplots(figsize=(10, 3.6))
    ax.plot(morph["frame"], morph["eigenlip1_real"], color="k", lw=2, label="real")
    curves = (
        ("morph", "-", "paper (morph)"),
        ("learned", "-", "learned"),
        ("trained", "-", "trained"),
        ("trained_heard", "-", "trained, heard"),
        ("trained_previous", "-.", "trained, previous settings"),
        ("dissolve", ":", "dissolve"),
        ("flipbook", "--", "flip-book"),
    )
    for renderer, style, label in curves:
        rows = part[part["renderer"] == renderer]
        if len(rows):
            ax.plot(rows["frame"], rows["eigenlip1_synth"], style, label=label)
    with open(phones_json, encoding="utf-8") as f:
        said = json.load(f)
    fps = said["fps"]
    for phone in said["phones"]:
        if phone["name"] != "pau":
            mid = (phone["start"] + phone["end"]) / 2 * fps
            ax.axvline(phone["start"] * fps, color="0.85", lw=0.8, zorder=0)
            ax.text(mid, 1.01, phone["name"], transform=ax.get_xaxis_transform(), ha="center",
                    fontsize=7)  # fmt: skip
    ax.set_xlabel(f"frame ({fps:g} fps)")
    ax.set_ylabel("eigenlip 1")
    ax.set_title(f"held-out clip {clip}: first eigenlip coefficient, real vs synthesized", pad=14)
    ax.legend(fontsize=8, loc="lower right")
    _save(fig, out)


def heldout_psnr(frames_csv: Path_, out: Path_, *, clip: str, model: str) -> None:
    """Mouth PSNR per frame of one held-out clip, for the morph and the baselines (the
    calibration rows, the real frames late, left out)."""
    table = pd.read_csv(frames_csv)
    part = table[(table["clip"] == clip) & (table["model"] == model)]
    part = part[~part["renderer"].str.startswith("real_late")]
    fig, ax = plt.subplots(figsize=(10, 3.2))
    for renderer, rows in part.groupby("renderer", sort=False):
        ax.plot(
            rows["frame"], rows["psnr_mouth"], label=renderer, lw=1.5 if renderer == "morph" else 1
        )
    ax.set_xlabel("frame")
    ax.set_ylabel("mouth PSNR (dB)")
    ax.set_title(f"held-out clip {clip}: mouth PSNR per frame")
    ax.legend(fontsize=8)
    _save(fig, out)


#: The training-clips figure's renderers and measures (mean and sd over the held-out clips).
SWEEP_RENDERERS = ("morph", "learned", "trained", "trained_heard")
SWEEP_MEASURES = (
    ("mouth_lmd", "mouth LMD (px)"),
    ("lip_opening_corr_speech", "inner-lip opening r, speech"),
    ("lip_opening_amplitude_speech", "opening amplitude (synth / real sd)"),
    ("eigenlip1_corr_speech", "eigenlip 1 r, speech"),
    ("psnr_mouth", "mouth PSNR (dB)"),
    ("mouth_width_corr_speech", "mouth width r, speech"),
)


def training_clips(sweep_csv: Path_, out: Path_) -> None:
    """Held-out measures of each lip-sync model (:data:`SWEEP_RENDERERS`) of the face's own
    model (a sweep face measures only its own) against the number of training clips."""
    table = pd.read_csv(sweep_csv)
    own = table[table["renderer"] == "morph"].sort_values("training_clips")["model"].iloc[0]
    rows = table[(table["model"] == own) & table["renderer"].isin(SWEEP_RENDERERS)]
    measures = [(c, label) for c, label in SWEEP_MEASURES if f"{c}_mean" in table.columns]
    cols = 3
    lines = -(-len(measures) // cols)
    fig, axes = plt.subplots(lines, cols, figsize=(12, 3.4 * lines), squeeze=False)
    for ax, (column, label) in zip(axes.flat, measures, strict=False):
        for renderer in SWEEP_RENDERERS:
            part = rows[rows["renderer"] == renderer].sort_values("training_clips")
            if part.empty:
                continue
            ax.errorbar(part["training_clips"], part[f"{column}_mean"], yerr=part[f"{column}_sd"],
                        marker="o", capsize=3, label=renderer)  # fmt: skip
        ax.set_xscale("log", base=2)
        ax.set_xlabel("training clips")
        ax.set_ylabel(label)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("held-out clips: how much video must a user record (mean and sd over clips)")
    _save(fig, out)


FIGURES: dict[str, Callable[..., None]] = {
    "epe_vs_levels": epe_vs_levels,
    "morph_psnr_vs_alpha": morph_psnr_vs_alpha,
    "sync_vs_max_px": sync_vs_max_px,
    "sampling_vs_max_px": sampling_vs_max_px,
    "sampling_strip": sampling_strip,
    "lipsync_diagram": lipsync_diagram,
    "morph_strip": morph_strip,
    "heldout_trajectory": heldout_trajectory,
    "heldout_psnr": heldout_psnr,
    "training_clips": training_clips,
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
