"""A face from one video against the same face from its clips: phones and held-out measures.

When the video is clips joined (:mod:`miketalk_lab.bench.joined`), the face built
from it should be the face built from the clips, within the aligner's accuracy:

- :func:`phone_errors`: each utterance of the video's corpus is paired with the
  clip it overlaps most; their spoken phones (pauses left out) must be the same
  sequence, and every phone boundary is measured in the joined video's time;
- :func:`heldout_of_model`: a model measured on held-out clips (the clip files
  themselves, never read to build either model) with the held-out evaluation of
  the workflow (:func:`miketalk_lab.evaluation.heldout.heldout_stage`), in its own
  corpus's frame;
- :func:`compare_heldout`: the two models' held-out measures paired clip by clip.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = [
    "HELDOUT_MEASURES",
    "compare_heldout",
    "heldout_of_model",
    "pair_utterances",
    "phone_errors",
]

#: The held-out measures compared (``clips.csv`` of the held-out evaluation).
HELDOUT_MEASURES = (
    "psnr_mouth",
    "mouth_lmd",
    "lip_opening_corr_speech",
    "lip_opening_amplitude_speech",
    "opening_corr_speech",
    "ssim_mouth",
)


def pair_utterances(segments: Mapping, spans: pd.DataFrame) -> dict[str, str]:
    """Each utterance of ``segments.json``: the joined clip (``clips.tsv``) it overlaps most."""
    ends = spans["start"] + spans["duration"]
    pairs = {}
    for u in segments["utterances"]:
        overlap = np.minimum(u["end"], ends) - np.maximum(u["start"], spans["start"])
        pairs[u["id"]] = str(spans["clip"].iloc[int(np.argmax(overlap))])
    return pairs


def phone_errors(
    video_corpus: str | Path,
    segments: Mapping,
    clips_corpus: str | Path,
    spans: pd.DataFrame,
) -> pd.DataFrame:
    """The phone boundaries of a one-video corpus against its clips corpus, in video time.

    Parameters
    ----------
    video_corpus, clips_corpus : path
        The two corpus folders (their ``phones.tsv``).
    segments : mapping
        The video's ``segments.json``.
    spans : DataFrame
        The join's ``clips.tsv`` (where each clip is in the joined video).

    Returns
    -------
    DataFrame
        One row per boundary of the spoken phones (each phone's start, and its end
        where a pause or the utterance's end follows) of every utterance whose
        clip is in the clips corpus: ``utterance``, ``clip``, ``same_phones``
        (whether the two spoken sequences are equal; the times are compared only
        then), ``phone``, ``ours_s``, ``clips_s``, ``error_ms``.
    """
    from miketalk.corpus.clips import PHONES_TABLE

    def spoken(corpus: str | Path) -> pd.DataFrame:
        table = pd.read_csv(Path(corpus) / PHONES_TABLE, sep="\t", keep_default_na=False)
        return table[table["phone"] != "pau"]

    ours, theirs = spoken(video_corpus), spoken(clips_corpus)
    clip_start = dict(zip(spans["clip"], spans["start"], strict=True))
    utterance_start = {u["id"]: u["start"] for u in segments["utterances"]}
    rows = []
    for utterance, clip in pair_utterances(segments, spans).items():
        a = ours[ours["clip"] == utterance]
        b = theirs[theirs["clip"] == clip]
        if a.empty or b.empty:  # not in both corpora (held out, or skipped)
            continue
        same = list(a["phone"]) == list(b["phone"])
        if not same:
            rows.append({"utterance": utterance, "clip": clip, "same_phones": False})
            continue
        a_start = a["clip_start"].to_numpy() + utterance_start[utterance]
        a_end = a["clip_end"].to_numpy() + utterance_start[utterance]
        b_start = b["clip_start"].to_numpy() + clip_start[clip]
        b_end = b["clip_end"].to_numpy() + clip_start[clip]
        for i, phone in enumerate(b["phone"]):
            pairs = [(a_start[i], b_start[i])]
            if i + 1 == len(b_start) or b_end[i] < b_start[i + 1] - 1e-6:
                pairs.append((a_end[i], b_end[i]))
            for mine, clips_s in pairs:
                rows.append(
                    {
                        "utterance": utterance,
                        "clip": clip,
                        "same_phones": True,
                        "phone": phone,
                        "ours_s": round(float(mine), 5),
                        "clips_s": round(float(clips_s), 5),
                        "error_ms": round(1000 * float(mine - clips_s), 2),
                    }
                )
    return pd.DataFrame(rows)


def heldout_of_model(
    model_dir: str | Path,
    corpus_dir: str | Path,
    clips: Sequence,
    out_dir: str | Path,
    *,
    name: str,
    morph: Mapping | None = None,
    grouping: Mapping | None = None,
) -> pd.DataFrame:
    """A model's held-out measures on ``clips`` (the ``clips.csv`` table), in its corpus's frame.

    ``name`` is the model's name in the table (the clips-built face's own model's
    name, to pair the two); the tables and side-by-side videos go to ``out_dir``.
    """
    from miketalk.corpus.eigenlips import read_eigenlips
    from miketalk_lab.evaluation.heldout import heldout_stage

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    eigenlips = Path(corpus_dir) / "eigenlips.npz"
    heldout_stage(
        corpus_dir=Path(corpus_dir),
        models={name: str(model_dir)},
        default_model=name,
        clips=list(clips),
        grouping=dict(grouping or {}),
        morph=dict(morph) if morph else None,
        frames_csv=out / "frames.csv",
        clips_csv=out / "clips.csv",
        summary_csv=out / "summary.csv",
        videos_dir=out / "videos",
        corpus_eigenlips=read_eigenlips(eigenlips) if eigenlips.is_file() else None,
    )
    return pd.read_csv(out / "clips.csv")


def compare_heldout(
    clips_built: pd.DataFrame,
    video_built: pd.DataFrame,
    *,
    model: str,
    renderers: Sequence[str] = ("morph", "learned"),
) -> pd.DataFrame:
    """Two models' held-out measures on the same clips, paired clip by clip.

    ``clips_built`` and ``video_built`` are held-out ``clips.csv`` tables; ``model``
    the name of the face's own model in both. Per renderer and measure: both
    means and standard deviations over the clips, the paired difference's mean,
    sd and largest size, and whether its mean lies within the clips-built
    model's spread over the clips (one sd).
    """
    rows = []
    for renderer in renderers:
        a = clips_built[(clips_built["renderer"] == renderer) & (clips_built["model"] == model)]
        b = video_built[(video_built["renderer"] == renderer) & (video_built["model"] == model)]
        if a.empty or b.empty:
            continue
        a, b = a.set_index("clip"), b.set_index("clip")
        common = a.index.intersection(b.index)
        a, b = a.loc[common], b.loc[common]
        for measure in (m for m in HELDOUT_MEASURES if m in a and m in b):
            diff = b[measure] - a[measure]
            sd = a[measure].std(ddof=1)
            rows.append(
                {
                    "renderer": renderer,
                    "measure": measure,
                    "clips": int(diff.notna().sum()),
                    "clips_built_mean": a[measure].mean(),
                    "clips_built_sd": sd,
                    "video_built_mean": b[measure].mean(),
                    "video_built_sd": b[measure].std(ddof=1),
                    "paired_diff_mean": diff.mean(),
                    "paired_diff_sd": diff.std(ddof=1),
                    "paired_diff_max_abs": diff.abs().max(),
                    "within_spread": bool(abs(diff.mean()) <= sd),
                }
            )
    return pd.DataFrame(rows)
