"""The training clips as the trajectory models see them, and what the models are fitted with.

:func:`training_set` reads each training clip's aligned phones, frame times,
descriptions and recording from a corpus folder into a :class:`TrainingSet`;
:class:`FitSettings` are the settings that change what is fitted (unlike the
selection's, :class:`~miketalk.draw.trained.selection.SelectionSettings`, which
change only how a face draws); :func:`clip_offsets` are the clips' mean
descriptions, which a ``centred`` fit leaves out.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.draw.trained.mouths import MouthFrames
from miketalk.speech.acoustic import Recording
from miketalk.speech.types import Phone


@dataclass(frozen=True)
class FitSettings:
    """What the trajectories are fitted with: to change one, fit the face again.

    Attributes
    ----------
    centred : bool
        The trajectories predict, and the selection's target cost compares, each frame's
        description less its clip's mean (what differs between recording sessions is left
        out); the join cost still compares the frames as they are.
    half : int
        The window regressions' phone context, frames each side.
    leave_unsure : bool
        The frames of words heard without confidence (the corpus's ``unsure.tsv``:
        :mod:`miketalk.corpus.unsure`) are left out of every fit and of its scoring (they
        can still be drawn); False fits them as their phones label them (the way before).
    """

    centred: bool = False
    half: int = 6
    leave_unsure: bool = True

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return dict(self.__dict__)


@dataclass(frozen=True)
class TrainingSet:
    """The training frames as the models see them: per clip, phones, frame times, descriptions."""

    phones: tuple[tuple[Phone, ...], ...]
    times: tuple[np.ndarray, ...]
    coords: tuple[np.ndarray, ...]
    recordings: tuple[Recording, ...] | None = None  # each clip's sound, for ``heard``
    #: Per clip, the frames the fits learn from and are scored on (None: every frame).
    kept: tuple[np.ndarray, ...] | None = None

    def fitted_rows(self, per_clip) -> list[np.ndarray]:
        """Each clip's array (one per clip, a row per frame) cut to its :attr:`kept` frames."""
        if self.kept is None:
            return list(per_clip)
        return [a[k] for a, k in zip(per_clip, self.kept, strict=True)]

    def kept_rows(self) -> list[np.ndarray]:
        """Each clip's :attr:`kept` frames, as row indices into the clip."""
        return self.fitted_rows([np.arange(len(c)) for c in self.coords])

    def folds(self, k: int) -> list[tuple[list[int], list[int]]]:
        """``k`` (train, validation) splits of the clips, every ``k``-th clip held out."""
        n = len(self.phones)
        return [
            ([i for i in range(n) if i % k != f], [i for i in range(n) if i % k == f])
            for f in range(min(k, n))
        ]


def training_set(
    corpus_dir: str | os.PathLike[str], frames: MouthFrames, *, leave_unsure: bool = True
) -> TrainingSet:
    """Each training clip's aligned phones (``phones.tsv``), frame times, descriptions and
    sound (``audio.wav`` from the clip's start in ``clips.tsv``); with ``leave_unsure``, the
    frames of the words heard without confidence (:func:`~miketalk.corpus.unsure.unsure_frames`)
    are not :attr:`~TrainingSet.kept`."""
    import pandas as pd

    from miketalk.corpus.unsure import unsure_frames
    from miketalk.media.audio import read_wav

    phones_table = pd.read_csv(Path(corpus_dir) / "phones.tsv", sep="\t", dtype={"clip": str})
    clips = pd.read_csv(Path(corpus_dir) / "clips.tsv", sep="\t", dtype={"clip": str})
    starts = dict(zip(clips["clip"], clips["start"], strict=True))
    samples, rate = read_wav(Path(corpus_dir) / "audio.wav")
    phones, times, coords, recordings = [], [], [], []
    for c, clip_id in enumerate(frames.clip_ids):
        own = phones_table[phones_table["clip"] == clip_id].sort_values("index")
        phones.append(
            tuple(
                Phone(str(p.phone), float(p.clip_start), float(p.clip_end))
                for p in own.itertuples()
            )
        )
        rows = np.flatnonzero(frames.clip == c)
        times.append(frames.clip_frame[rows] / frames.fps)
        coords.append(frames.coords[rows])
        first = round(float(starts[clip_id]) * rate)
        last = first + round(len(rows) / frames.fps * rate)
        recordings.append(Recording(samples[first:last], rate))
    kept = None
    if leave_unsure:
        unsure = unsure_frames(corpus_dir, frames.clip_ids, frames.clip, frames.clip_frame,
                               frames.fps)  # fmt: skip
        if unsure.any():
            kept = tuple(~unsure[frames.clip == c] for c in range(len(frames.clip_ids)))
    return TrainingSet(tuple(phones), tuple(times), tuple(coords), tuple(recordings), kept)


def clip_offsets(frames: MouthFrames) -> np.ndarray:
    """``(clips, n)``: each clip's mean description (its session's light and pose, which
    the phones cannot predict)."""
    count = np.bincount(frames.clip, minlength=len(frames.clip_ids)).astype(float)
    sums = np.stack(
        [np.bincount(frames.clip, frames.coords[:, d], len(frames.clip_ids))
         for d in range(frames.coords.shape[1])], axis=1,
    )  # fmt: skip
    return sums / np.maximum(count, 1.0)[:, None]


__all__ = ["FitSettings", "TrainingSet", "clip_offsets", "training_set"]
