"""The spans of a corpus's clips where a recognizer heard words without confidence.

A face built from one video with no script (:mod:`miketalk.corpus.heard_script`) leaves out
the words heard without confidence, but not their sound: it stays inside the utterances, and
the aligner labels it as a pause or stretches a neighbour's phones over it. Fitted as such,
those frames teach the trained face the wrong mouth for those labels (docs/recognize.md,
"Why the trained face's amplitude moves"). :func:`write_unsure` records the spans in the
corpus (``unsure.tsv``: clip, word, clip seconds), from ``segments.json``'s
``not_confident`` words placed through the corpus's ``sources.tsv``; :func:`unsure_frames`
says which training frames overlap one, for the fits to leave out
(:func:`miketalk.draw.trained.training.training_set`). A corpus without the file (clips,
or a script given) has none.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.media.atomic import write_text_atomic

#: The corpus's table of unsure spans.
UNSURE_TABLE = "unsure.tsv"

#: Seconds a frame must overlap a span by to count as inside it (frame and word edges that
#: coincide are not an overlap).
EDGE = 1e-6


def write_unsure(corpus_dir: str | Path, segments: str | Path) -> int:
    """Write the corpus's ``unsure.tsv``: each word ``segments`` (``segments.json``) names as
    heard without confidence, cut to each clip it overlaps, in that clip's seconds (the clip,
    or its piece, placed in the video by the corpus's ``sources.tsv``, which a corpus of a
    video's parts holds; a segmentation with no such word needs none). Returns how many
    spans."""
    from miketalk.corpus.clips import SOURCES_TABLE

    corpus = Path(corpus_dir)
    words = json.loads(Path(segments).read_text(encoding="utf-8")).get("not_confident", ())
    lines = ["clip\tword\tclip_start\tclip_end"]
    sources = (
        pd.read_csv(corpus / SOURCES_TABLE, sep="\t", dtype={"clip": str})
        if words
        else pd.DataFrame(columns=["clip", "first_frame", "frames", "fps"])
    )
    for c in sources.itertuples():
        lo, hi = c.first_frame / c.fps, (c.first_frame + c.frames) / c.fps
        for w in words:
            start, end = max(float(w["start"]), lo), min(float(w["end"]), hi)
            if end - start > EDGE:
                word = str(w["word"]).replace("\t", " ").replace("\n", " ")
                lines.append(f"{c.clip}\t{word}\t{start - lo:.6f}\t{end - lo:.6f}")
    write_text_atomic(corpus / UNSURE_TABLE, "\n".join(lines) + "\n")
    return len(lines) - 1


def unsure_frames(
    corpus_dir: str | Path,
    clip_ids: tuple[str, ...],
    clip: np.ndarray,
    clip_frame: np.ndarray,
    fps: float,
) -> np.ndarray:
    """``(N,)`` bool: the frames (clip ``clip_ids[clip]``, its frame ``clip_frame``, each
    ``1 / fps`` long) that overlap a span of the corpus's ``unsure.tsv`` (none without it)."""
    out = np.zeros(len(clip), bool)
    path = Path(corpus_dir) / UNSURE_TABLE
    if not path.is_file():
        return out
    spans = pd.read_csv(path, sep="\t", dtype={"clip": str}, keep_default_na=False)
    index = {c: k for k, c in enumerate(clip_ids)}
    start = np.asarray(clip_frame, float) / fps
    for s in spans.itertuples():
        if s.clip in index:
            inside = (np.asarray(clip) == index[s.clip]) & (start < s.clip_end - EDGE)
            out |= inside & (start + 1.0 / fps > s.clip_start + EDGE)
    return out


__all__ = ["UNSURE_TABLE", "unsure_frames", "write_unsure"]
