"""The corpus folder: the one format every recording is brought into, and its one reader.

Whatever the source (the synthetic face, a person's video of the corpus words,
or clips of ordinary speech), the corpus stage writes::

    frames/000000.png ...  the video frames, numbered from 0 (:func:`frame_name`)
    audio.wav              the sound, mono
    words.json             fps, size, audio rate, and the spoken words with the
                           phones of each (Festival's prediction, or the aligner's)
    frames.tsv             one row per frame: frame, time (and, for the synthetic
                           face, the true mouth parameters)
    truth.tsv              hidden ground truth of the corpus targets (header only
                           where there is none)
    corpus.mp4             the recording as a video, to look at

and every later stage reads it through :func:`open_corpus`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.images import read_image

FRAMES = "frames"
AUDIO = "audio.wav"
WORDS = "words.json"
FRAMES_TABLE = "frames.tsv"
TRUTH = "truth.tsv"
VIDEO = "corpus.mp4"

#: ``truth.tsv``'s columns (a recording without ground truth has only this header).
TRUTH_COLUMNS = ("key", "word", "phone", "time", "frame")


def frame_name(index: int) -> str:
    """The file name of frame ``index``: ``000123.png``."""
    return f"{index:06d}.png"


def frame_path(frames_dir: str | Path, index: int) -> Path:
    """``frames_dir / frame_name(index)``."""
    return Path(frames_dir) / frame_name(index)


def count_frames(frames_dir: str | Path) -> int:
    """How many frames a ``frames/`` directory holds."""
    return sum(1 for _ in Path(frames_dir).glob("*.png"))


def frames_table_text(n_frames: int, fps: float) -> str:
    """``frames.tsv`` of a recording without per-frame truth: frame and time."""
    return "frame\ttime\n" + "".join(f"{k}\t{k / fps:.6f}\n" for k in range(n_frames))


def empty_truth_text() -> str:
    """``truth.tsv`` of a recording without ground truth."""
    return "\t".join(TRUTH_COLUMNS) + "\n"


def words_doc(
    *, fps: float, size: tuple[int, int] | list[int] | int, rate: int, words: list[dict], **extra
) -> str:
    """``words.json``: frame rate, frame size, audio rate, and each word with its phones."""
    return json.dumps({"fps": fps, "size": size, "rate": rate, **extra, "words": words}, indent=1)


@dataclass(frozen=True)
class CorpusVideo:
    """A corpus folder on disk, opened by :func:`open_corpus`.

    Attributes
    ----------
    directory : Path
        The corpus folder.
    fps : float
        Frame rate.
    words : list of str
        The spoken words, in order.
    """

    directory: Path
    fps: float
    words: list[str]

    @property
    def frames_dir(self) -> Path:
        """``frames/``."""
        return self.directory / FRAMES

    @property
    def audio_path(self) -> Path:
        """``audio.wav``."""
        return self.directory / AUDIO

    @cached_property
    def n_frames(self) -> int:
        """Frames in the recording (counted once: a corpus folder is complete when opened,
        and counting lists the directory)."""
        return count_frames(self.frames_dir)

    @property
    def frame_paths(self) -> list[Path]:
        """The frame files in order."""
        return [frame_path(self.frames_dir, k) for k in range(self.n_frames)]

    def frame(self, index: int) -> np.ndarray:
        """Frame ``index`` as (H, W, 3) uint8 RGB."""
        n = self.n_frames
        if not 0 <= index < n:
            raise MiketalkError(f"frame {index} is outside the recording (0..{n - 1})")
        return read_image(frame_path(self.frames_dir, index))

    def metadata(self) -> dict:
        """``words.json`` as a dict."""
        return json.loads((self.directory / WORDS).read_text())


def open_corpus(directory: str | Path, *, words: list[str] | None = None) -> CorpusVideo:
    """Open a corpus folder (any source), checking that it is complete.

    Raises
    ------
    MiketalkError
        When ``words.json``, ``frames/`` or ``audio.wav`` is missing.
    """
    directory = Path(directory)
    meta_path = directory / WORDS
    if not meta_path.exists():
        raise MiketalkError(f"{directory} is not a corpus recording: no {WORDS}")
    meta = json.loads(meta_path.read_text())
    if not (directory / FRAMES).is_dir() or not (directory / AUDIO).exists():
        raise MiketalkError(f"{directory} lacks {FRAMES}/ or {AUDIO}")
    return CorpusVideo(directory, float(meta["fps"]), words or [w["word"] for w in meta["words"]])
