"""One build's phones given to another build's frames.

The :mod:`miketalk_lab.bench.amplitude_cause` bench's corpus surgery: two builds of the same
joined video (:mod:`miketalk_lab.bench.recognized_build`) cut it into utterances differently;
:func:`joined_phones` places a corpus's phones in the joined video's time, :func:`relabelled`
gives them to the other corpus's clips (:func:`clip_phones`).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import pandas as pd


def joined_phones(corpus: Path) -> list[tuple[float, float, str]]:
    """A corpus's phones as ``(start, end, name)`` in the time of the video its clips were
    cut from (``sources.tsv``'s first frame of each clip, ``phones.tsv``'s clip times)."""
    sources = pd.read_csv(corpus / "sources.tsv", sep="\t", dtype={"clip": str}).set_index("clip")
    phones = pd.read_csv(corpus / "phones.tsv", sep="\t", dtype={"clip": str})
    out = []
    for p in phones.itertuples():
        start = float(sources.loc[p.clip, "first_frame"]) / float(sources.loc[p.clip, "fps"])
        out.append((start + float(p.clip_start), start + float(p.clip_end), str(p.phone)))
    return out


def _pieces(phones, lo: float, hi: float, windows, inside: bool) -> list[list]:
    """``phones`` cut to ``[lo, hi)`` and to the parts inside (or outside) ``windows``."""
    out = []
    for start, end, name in phones:
        start, end = max(start, lo), min(end, hi)
        if end <= start:
            continue
        if windows is None:
            if inside:
                out.append([start, end, name])
            continue
        edges = sorted({start, end, *(x for w in windows for x in w if start < x < end)})
        for a, b in itertools.pairwise(edges):
            middle = (a + b) / 2
            if any(w0 <= middle < w1 for w0, w1 in windows) == inside:
                out.append([a, b, name])
    return out


def clip_phones(ours, theirs, lo: float, hi: float, windows=None) -> list[tuple[float, float, str]]:
    """The phones of one clip ``[lo, hi)`` of the joined video: ``theirs`` (inside
    ``windows`` only, when given; ``ours`` elsewhere), the gaps filled with ``pau``, a phone
    cut by a window's edge joined again."""
    segs = _pieces(theirs, lo, hi, windows, True)
    if windows is not None:
        segs += _pieces(ours, lo, hi, windows, False)
    filled, t = [], lo
    for start, end, name in sorted(segs):
        if start > t + 1e-9:
            filled.append([t, start, "pau"])
        filled.append([start, end, name])
        t = end
    if t < hi - 1e-9:
        filled.append([t, hi, "pau"])
    merged: list[list] = []
    for start, end, name in filled:
        joins = windows is not None or name == "pau"
        if merged and merged[-1][2] == name and abs(merged[-1][1] - start) < 1e-9 and joins:
            merged[-1][1] = end
        else:
            merged.append([start, end, name])
    return [(a, b, n) for a, b, n in merged]


def relabelled(target: Path, source: Path, dest: Path, *, windows=None, shift: float = 0.0) -> Path:
    """Corpus ``target`` with ``source``'s phones (:func:`clip_phones`; ``shift`` seconds
    later), as a folder ``dest`` of links to ``target``'s files and a new ``phones.tsv``."""
    dest.mkdir(parents=True, exist_ok=True)
    for f in target.iterdir():
        if f.name != "phones.tsv" and not (dest / f.name).exists():
            (dest / f.name).symlink_to(f.resolve())
    theirs = [(a + shift, b + shift, n) for a, b, n in joined_phones(source)]
    ours = joined_phones(target)
    rows = []
    for c in pd.read_csv(target / "sources.tsv", sep="\t", dtype={"clip": str}).itertuples():
        lo, hi = c.first_frame / c.fps, (c.first_frame + c.frames) / c.fps
        for k, (a, b, name) in enumerate(clip_phones(ours, theirs, lo, hi, windows)):
            rows.append({"clip": c.clip, "index": k, "phone": name, "start": a, "end": b,
                         "clip_start": round(a - lo, 6), "clip_end": round(b - lo, 6)})  # fmt: skip
    pd.DataFrame(rows).to_csv(dest / "phones.tsv", sep="\t", index=False)
    return dest


__all__ = ["clip_phones", "joined_phones", "relabelled"]
