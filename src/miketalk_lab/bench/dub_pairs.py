"""Held-out dubs of face-crop models summed up: the dub against the same render, clip by clip.

``python -m miketalk_lab.bench.dub_pairs NAME=DIR [NAME=DIR ...]`` reads each ``DIR/clips.csv``
(and ``DIR/times.tsv`` when there) that ``python -m miketalk_lab.evaluation.dub_heldout ...
--times DIR/times.tsv`` wrote for a face-crop model, and prints, per NAME, a markdown table:
the dubbed frames against the render before paste-back (both read in the corpus's crop
pixels against the real clip), paired clip by clip (:func:`~miketalk_lab.evaluation.paired.
paired`: means, standard deviations, the difference's mean and 95 % t interval), for dlib's
lip-opening amplitude and r over the speech and the mouth LMD; then the full-resolution
measures (seam ratio, PSNR outside the mask, bit-identical shares) and the dub's time per
clip, each with its mean's 95 % t interval. With ``--strip``, also ``DIR/strip.png``: the
first 40 frames of the first clip's side-by-side mp4, every 5th, real above dubbed, whole
(about 256 px wide) and cropped to where the dub changed them
(:func:`~miketalk_lab.bench.dub_detail.changed_box`: the head moves, the box holds it all).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from miketalk_lab.evaluation.paired import paired

#: Measured on the dub and on the render, paired (``dub_<m>`` against ``render_<m>``).
PAIRED = ("lip_opening_amplitude_speech", "lip_opening_corr_speech", "mouth_lmd",
          "mouth_lmd_speech", "psnr_mouth")  # fmt: skip

#: Measured once per clip (the full-resolution frames; the amplitude the dub keeps).
SINGLE = ("amplitude_kept", "seam_ratio", "psnr_frame", "psnr_outside", "identical_share",
          "identical_outside_box", "moved_outside_px", "psnr_encoded", "untracked")  # fmt: skip


def one(values: pd.Series) -> dict[str, float]:
    """A measure's mean, sd and its mean's 95 % t interval (:func:`paired` against 0)."""
    out = paired(pd.Series(0.0, index=values.index), values)
    return {"clips": out["clips"], "mean": out["diff_mean"], "sd": out["diff_sd"],
            "low": out["diff_low"], "high": out["diff_high"]}  # fmt: skip


def report(name: str, folder: Path) -> str:
    """The markdown of one model's dub (see the module docstring)."""
    table = pd.read_csv(folder / "clips.csv").set_index("clip")
    lines = [f"## {name} ({len(table)} clips, {table['renderer'].iloc[0]})", "",
             "| measure | rendered mean (sd) | dubbed mean (sd) | dubbed - rendered (sd) | "
             "95 % interval |", "| --- | --- | --- | --- | --- |"]  # fmt: skip
    for m in PAIRED:
        p = paired(table[f"render_{m}"], table[f"dub_{m}"])
        lines.append(
            f"| {m} | {p['a_mean']:.3f} ({p['a_sd']:.3f}) | {p['b_mean']:.3f} ({p['b_sd']:.3f}) "
            f"| {p['diff_mean']:+.3f} ({p['diff_sd']:.3f}) | [{p['diff_low']:+.3f}, "
            f"{p['diff_high']:+.3f}] |"
        )
    lines += [
        "",
        "| measure | mean (sd) | 95 % interval | min | max |",
        "| --- | --- | --- | --- | --- |",
    ]
    singles = {m: table[m] for m in SINGLE if m in table}
    times = folder / "times.tsv"
    if times.is_file():
        singles["dub seconds"] = pd.read_csv(times, sep="\t").set_index("clip")["seconds"]
    for m, values in singles.items():
        finite = values[values.map(math.isfinite)]
        s = one(finite) if len(finite) else None
        shown = (f"{s['mean']:.4g} ({s['sd']:.3g}) | [{s['low']:.4g}, {s['high']:.4g}]"
                 if s else "inf | ")  # fmt: skip
        extra = "" if len(finite) == len(values) else f" ({len(values) - len(finite)} inf)"
        lines.append(f"| {m}{extra} | {shown} | {values.min():.4g} | {values.max():.4g} |")
    return "\n".join(lines)


def write_strip(folder: Path, clip: str, *, frames: int = 40) -> Path:
    """``folder/strip.png`` of ``folder/<clip>.mp4`` (see the module docstring)."""
    from miketalk.media.decode import read_video
    from miketalk.media.images import write_png
    from miketalk_lab.bench.dub_detail import changed_box
    from miketalk_lab.figures.dub_strip import strip

    video, _ = read_video(folder / f"{clip}.mp4", frames=frames)
    half = video.shape[2] // 2
    real, dubbed = video[:, :, :half], video[:, :, half:]
    box = None
    for k in range(len(video)):
        found = changed_box(real[k], [dubbed[k]])
        if found is not None:
            rows, cols = found
            here = (rows.start, cols.start, rows.stop, cols.stop)
            box = here if box is None else (min(box[0], here[0]), min(box[1], here[1]),
                                            max(box[2], here[2]), max(box[3], here[3]))  # fmt: skip
    mouth = None if box is None else (box[1], box[0], box[3] - box[1], box[2] - box[0])
    out = folder / "strip.png"
    write_png(out, strip(video, split=2, mouth=mouth, scale=min(1.0, 256 / half)))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("runs", nargs="+", help="NAME=DIR, DIR holding clips.csv")
    parser.add_argument("--strip", action="store_true", help="also DIR/strip.png")
    args = parser.parse_args(argv)
    parts = []
    for run in args.runs:
        name, sep, folder = run.partition("=")
        if not sep:
            parser.error(f"{run!r}: give NAME=DIR")
        parts.append(report(name, Path(folder)))
        if args.strip:
            first = pd.read_csv(Path(folder) / "clips.csv")["clip"].iloc[0]
            parts.append(f"Strip: {write_strip(Path(folder), str(first))} (clip {first}).")
    print("\n\n".join(parts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
