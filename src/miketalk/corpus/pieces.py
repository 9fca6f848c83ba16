"""An utterance cut at the frames its tracker left out: the words on either side kept.

An utterance cut from one long video (:mod:`miketalk.corpus.one_video`) can hold frames
where the tracker found no one frontal face (the head turned away, a second face in the
picture, the face out of it: :mod:`miketalk.track`). Such frames are left out, never
forced; one of them in the speech used to cost the whole utterance (:mod:`miketalk.corpus.
steady`: a hole in the speech would tear the timing), 4.5 s of speech for 1.3 s without
the face. Now the utterance is cut at word boundaries (the aligner's words): each run of
words whose frames are all tracked, with no frame left out in the pauses between them, is
an utterance of its own (``<id>.<k>``), and the words over frames left out are dropped and
named. No word's sound is split between a piece kept and a part dropped: a piece ends where
the next dropped word's first frame starts and starts after the last frame of the dropped
word before it.

A piece shorter than :data:`MIN_PIECE_SECONDS` is dropped and named too (see there). An
utterance of which no piece is kept is left to :func:`~miketalk.corpus.steady.
stabilize_clip`, which names it whole as before; one whose frames left out are all outside
its speech is not cut here (the stabilization leaves them out with what is beyond them).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from miketalk.corpus.clip_sources import Clip, DecodedClip
from miketalk.corpus.steady import speech_span
from miketalk.track.result import failure_ranges

#: A piece of an utterance shorter than this (s) is dropped. The corpus's stages see a
#: piece as a clip of its own: the dominance fit compares each clip's mouth trajectory
#: less its moving average over 0.6 s (:func:`~miketalk.draw.coarticulation.fit.
#: detrender`, edges replicated), so a shorter clip is all edge and its motion goes with its
#: trend; the trained lip-sync's phone context is 6 frames either side (0.4 s at 30 fps,
#: :class:`~miketalk.draw.trained.training.FitSettings`), and its centred form takes each
#: clip's mean out, the mean of a few frames being their own content. At 0.6 s a piece
#: holds one or two words and the pauses around them.
MIN_PIECE_SECONDS = 0.6


def speech_pieces(part: DecodedClip) -> tuple[list[DecodedClip], list[tuple[Clip, str]]]:
    """``part`` cut at the frames left out in its speech (see the module docstring).

    Parameters
    ----------
    part : DecodedClip
        An utterance (or one shot of it) as decoded and aligned.

    Returns
    -------
    kept : list of DecodedClip
        The pieces to use, in order, each named ``<id>.<k>`` with its words as its text;
        ``[part]`` itself when there is nothing to cut (no frame left out in its speech, no
        word, or no piece kept).
    dropped : list of (Clip, str)
        Each part dropped (its span in the video) and why, for the skipped table.
    """
    tracked = part.tracked
    n, fps = len(part.frames), part.fps
    if tracked is None or tracked.all() or not part.words:
        return [part], []
    out = np.flatnonzero(~tracked)
    first, stop = speech_span(part.phones, fps, n)
    if not ((out >= first) & (out < stop)).any():
        return [part], []
    spans = []
    for w in part.words:
        a = min(n - 1, max(0, math.floor(w.start * fps + 1e-6)))
        spans.append((a, min(n, max(a + 1, math.ceil(w.end * fps - 1e-6)))))
    good = [bool(tracked[a:b].all()) for a, b in spans]
    runs: list[list[int]] = []  # consecutive words: all good with no gap left out, or all bad
    for i, ok in enumerate(good):
        joins = runs and good[runs[-1][-1]] == ok
        if joins and ok:
            joins = bool(tracked[spans[i - 1][1] : spans[i][0]].all())
        runs.append([*runs.pop(), i] if joins else [i])
    kept: list[DecodedClip] = []
    dropped: list[tuple[Clip, str]] = []
    for k, run in enumerate(runs, 1):
        i, j = run[0], run[-1]
        text = " ".join(part.words[w].word for w in run)
        name = f"{part.clip.id}.{k}"
        if not good[i]:
            a, b = spans[i][0], spans[j][1]
            why = f"{_words(run)} over frames left out ({_left_out(part, a, b)}): {text!r}"
            dropped.append((_named(part, a, b, name), why))
            continue
        before, after = out[out < spans[i][0]], out[out >= spans[j][1]]
        a = max(spans[i - 1][1] if i and not good[i - 1] else 0,
                int(before.max()) + 1 if before.size else 0)  # fmt: skip
        b = min(spans[j + 1][0] if j + 1 < len(spans) and not good[j + 1] else n,
                int(after.min()) if after.size else n)  # fmt: skip
        if b - a < MIN_PIECE_SECONDS * fps:
            why = (f"{_words(run)} between frames left out, a piece of {max(0, b - a)} frames "
                   f"(less than {MIN_PIECE_SECONDS:g} s): {text!r}")  # fmt: skip
            where = (a, b) if b > a else (spans[i][0], spans[j][1])  # no frame: its words'
            dropped.append((_named(part, *where, name), why))
        else:
            piece = part.cut(a, b)
            kept.append(replace(piece, clip=replace(piece.clip, id=name, text=text)))
    if not kept:
        return [part], []
    return kept, dropped


def _words(run: list[int]) -> str:
    return f"{len(run)} word{'s' * (len(run) != 1)}"


def _named(part: DecodedClip, a: int, b: int, name: str) -> Clip:
    """The clip of frames ``[a, b)`` of ``part`` (where they are in the video), named."""
    return replace(part.cut(a, b).clip, id=name)


def _left_out(part: DecodedClip, a: int, b: int) -> str:
    """``frame 283: no frontal face; frames 284-300: several faces``: the frames left out
    among ``[a, b)``, numbered in the video."""
    shift = part.clip.span[0] if part.clip.span is not None else 0
    return "; ".join(map(str, failure_ranges(part.left_out[a:b], start=a + shift)))


__all__ = ["MIN_PIECE_SECONDS", "speech_pieces"]
