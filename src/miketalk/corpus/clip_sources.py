"""The clips of a person a corpus is built from: media, transcripts and word timings, decoded."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming, read_word_timings
from miketalk.track.crop import FaceCropSettings

#: Sample rate of the corpus sound (the aligner's rate).
RATE = 16000


@dataclass(frozen=True)
class Clip:
    """One utterance of the corpus: its id, media file, transcript and word timings (if any).

    A clip is a whole media file, or, with ``span`` (first frame, number of
    frames), that part of a longer one (an utterance cut from one video,
    :mod:`miketalk.corpus.one_video`), whose word timings are then given as
    ``given_words`` (clip time) instead of a file. Its sound is read ``sound_lag``
    seconds later than its frames, the words as much earlier (the video's sound runs
    that much behind its mouth: :mod:`miketalk.corpus.sound_lag`).
    """

    id: str
    media: Path
    text: str
    timings: Path | None = None
    span: tuple[int, int] | None = None
    fps: float | None = None
    given_words: tuple[WordTiming, ...] | None = None
    sound_lag: float = 0.0

    @property
    def start(self) -> float:
        """Where the clip starts in its media file (seconds)."""
        return self.span[0] / self.fps if self.span is not None else 0.0

    @property
    def words(self) -> list[str]:
        """The transcript's words, lower case."""
        return self.text.lower().split()


@dataclass(frozen=True)
class DecodedClip:
    """A clip read and aligned: frames as recorded (or its face crops), sound, phones
    (clip time).

    ``left_out`` and ``to_crop`` are set when the frames are face crops
    (:func:`decode_clip` with ``crop``): per frame why the tracker left it out (None:
    the face was tracked), and each frame's map from the video's pixels to its crop's.
    """

    clip: Clip
    frames: np.ndarray
    fps: float
    samples: np.ndarray
    phones: tuple[Phone, ...]
    words: tuple[WordTiming, ...]
    left_out: tuple[str | None, ...] | None = None
    to_crop: np.ndarray | None = None
    cuts: tuple[int, ...] = ()

    def shots(self) -> list[DecodedClip]:
        """The clip cut at its shot changes (:attr:`cuts`, found by the tracker), each part
        a clip of its own named ``<id>.<k>`` (one shot: one light, one colour offset)."""
        if not self.cuts:
            return [self]
        bounds = [0, *self.cuts, len(self.frames)]
        parts = []
        for k, (a, b) in enumerate(itertools.pairwise(bounds), 1):
            part = self.cut(a, b)
            parts.append(replace(part, clip=replace(part.clip, id=f"{self.clip.id}.{k}")))
        return parts

    @property
    def tracked(self) -> np.ndarray | None:
        """``(N,)`` bool: the frames whose face was tracked (None: not face crops)."""
        if self.left_out is None:
            return None
        return np.array([why is None for why in self.left_out], dtype=bool)

    def cut(self, first: int, stop: int) -> DecodedClip:
        """Frames ``first`` to ``stop`` (exclusive), with their sound, phones and words.

        Times are taken from the new first frame, phones and words are cut at the
        ends (a phone left without duration goes), and ``clip`` says where the
        part is in its media file (:attr:`Clip.span`).
        """
        if not 0 <= first < stop <= len(self.frames):
            raise ValueError(f"cannot cut frames {first} to {stop} of {len(self.frames)}")
        t0, t1 = first / self.fps, stop / self.fps

        def moved(items):  # Phone or WordTiming: cut at the ends, timed from t0
            return tuple(
                replace(item, start=max(item.start, t0) - t0, end=min(item.end, t1) - t0)
                for item in items
                if min(item.end, t1) - max(item.start, t0) > 1e-9
            )

        before = self.clip.span[0] if self.clip.span is not None else 0
        given = self.clip.given_words
        clip = replace(
            self.clip,
            span=(before + first, stop - first),
            fps=self.fps,
            given_words=None if given is None else moved(given),
        )
        return DecodedClip(
            clip,
            self.frames[first:stop],
            self.fps,
            self.samples[round(t0 * RATE) : round(t1 * RATE)],
            moved(self.phones),
            moved(self.words),
            None if self.left_out is None else self.left_out[first:stop],
            None if self.to_crop is None else self.to_crop[first:stop],
            tuple(c - first for c in self.cuts if first < c < stop),
        )


class ClipError(MiketalkError):
    """A clip that cannot be used; the message names the clip."""


def read_transcripts(path: str | Path) -> dict[str, str]:
    """The ``id text`` table: one clip per line, the id first, then the words.

    Blank lines and lines starting with ``#`` are ignored.

    Raises
    ------
    MiketalkError
        If the file is missing, a line has no words, or an id repeats.
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"transcript table not found: {path}")
    table: dict[str, str] = {}
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        clip_id, _, text = line.partition(" ")
        if not text.strip():
            raise MiketalkError(f"{path}:{number}: clip {clip_id!r} has no words")
        if clip_id in table:
            raise MiketalkError(f"{path}:{number}: clip {clip_id!r} appears twice")
        table[clip_id] = " ".join(text.split())
    return table


def clip_sources(
    ids: Sequence[str],
    *,
    media: str,
    transcripts: str | Path,
    timings: str | None = None,
) -> list[Clip]:
    """The clips named by ``ids``, their files found through ``{id}`` patterns.

    Parameters
    ----------
    ids : sequence of str
        Which clips, in order.
    media : str
        Path pattern of a clip's video with sound, e.g. ``data/grid_s1/video/{id}.mpg``.
    transcripts : path
        The ``id text`` table (:func:`read_transcripts`).
    timings : str, optional
        Path pattern of a clip's word timings (``.align`` or ``.TextGrid``).

    Raises
    ------
    MiketalkError
        For a pattern without ``{id}``, an id the table lacks, a repeated id,
        or a media file that does not exist.
    """
    if not media or not transcripts:
        raise MiketalkError("a corpus of clips needs its media pattern and its transcript table")
    if not ids:
        raise MiketalkError("no clips named: list the clip ids to use")
    for name, pattern in (("media", media), ("timings", timings)):
        if pattern is not None and "{id}" not in pattern:
            raise MiketalkError(f"clips.{name} must contain {{id}}, got {pattern!r}")
    if len(set(ids)) != len(ids):
        raise MiketalkError("a clip id is listed twice")
    table = read_transcripts(transcripts)
    clips = []
    for clip_id in ids:
        if clip_id not in table:
            raise MiketalkError(f"clip {clip_id!r} is not in the transcript table {transcripts}")
        path = Path(media.replace("{id}", clip_id))
        if not path.is_file():
            raise MiketalkError(f"clip {clip_id}: media file not found: {path}")
        timing = Path(timings.replace("{id}", clip_id)) if timings else None
        clips.append(Clip(clip_id, path, table[clip_id], timing))
    return clips


def decode_clip(clip: Clip, *, crop: FaceCropSettings | None = None) -> DecodedClip:
    """Read a clip's frames and sound and align its phones.

    With ``crop``, the frames are the face's canonical crops (:func:`~miketalk.track.
    video_crops.crop_video`: the face tracked, then cropped; frames without one frontal
    face flagged in ``tracked``), at the crop's size whatever the video's.

    Raises
    ------
    ClipError
        No sound, a missing timing file, a word the aligner cannot place, or
        fewer frames than the clip's phones need; the message names the clip.
    """
    from miketalk.media.decode import read_media_audio, read_video
    from miketalk.speech.align import align

    left_out = to_crop = None
    cuts: tuple[int, ...] = ()
    try:
        if crop is not None:
            from miketalk.track.video_crops import crop_video

            count = clip.span[1] if clip.span is not None else None
            cropped = crop_video(clip.media, crop=crop, start=clip.start if count else None,
                                 frames=count, source=f"its video {clip.media.name}")  # fmt: skip
            frames, fps = cropped.crops, cropped.fps
            left_out = tuple(None if r is None else str(r) for r in cropped.track.reasons)
            to_crop, cuts = cropped.to_crop, tuple(cropped.track.cuts())
            samples = read_media_audio(
                clip.media, rate=RATE, start=clip.start + clip.sound_lag if count else None,
                duration=count / clip.fps if count else None,
            )  # fmt: skip
        elif clip.span is not None:
            frames, fps = read_video(clip.media, start=clip.start, frames=clip.span[1])
            samples = read_media_audio(
                clip.media, rate=RATE, start=clip.start + clip.sound_lag,
                duration=clip.span[1] / clip.fps,
            )  # fmt: skip
        else:
            frames, fps = read_video(clip.media)
            samples = read_media_audio(clip.media, rate=RATE)
        if clip.timings is not None and not clip.timings.is_file():
            raise MiketalkError(f"word timing file not found: {clip.timings}")
        words = read_word_timings(clip.timings) if clip.timings is not None else None
        if clip.given_words is not None:
            words = _lagged(clip.given_words, clip.sound_lag)
        if words is not None and [w.word.lower() for w in words] != clip.words:
            raise MiketalkError(
                f"the word timings ({' '.join(w.word for w in words)}) do not match the "
                f"transcript ({clip.text})"
            )
        if len(samples) < RATE // 10 or not np.abs(samples.astype(np.int32)).max() > 64:
            raise MiketalkError("it has no sound (silent or shorter than 0.1 s)")
        aligned = align(samples, RATE, clip.words, word_timings=words)
    except ClipError:
        raise
    except MiketalkError as err:
        raise ClipError(f"clip {clip.id}: {err}") from err
    spoken = [p for p in aligned.phones if p.name != "pau"]
    if spoken and spoken[-1].end > len(frames) / fps + 0.5 / fps:
        raise ClipError(
            f"clip {clip.id}: its video ({len(frames)} frames, {len(frames) / fps:.2f} s) ends "
            f"before its phones do ({spoken[-1].end:.2f} s)"
        )
    shortest = min((p.duration for p in spoken), default=1.0)
    if len(frames) < 3 or shortest <= 0:
        raise ClipError(f"clip {clip.id}: shorter than its phones")
    return DecodedClip(
        clip,
        frames,
        float(fps),
        samples,
        aligned.phones,
        aligned.words,
        left_out,
        to_crop,
        cuts,
    )


def _lagged(words: Sequence[WordTiming], lag: float) -> list[WordTiming]:
    """Words ``lag`` seconds earlier (their sound read that much later), none before 0."""
    if not lag:
        return list(words)
    out = []
    for w in words:
        start = max(0.0, w.start - lag)
        out.append(WordTiming(w.word, start, max(w.end - lag, start + 0.01)))
    return out


def _clipped(phones: Sequence[Phone], duration: float) -> list[Phone]:
    """The phones inside ``[0, duration]``, the last one ending exactly there."""
    out = [p for p in phones if p.start < duration - 1e-9]
    if out:
        last = out[-1]
        out[-1] = Phone(last.name, last.start, duration)
    return out


def _words(
    clip_id: str, words: Sequence[WordTiming], phones: Sequence[Phone], offset: float
) -> list[dict]:
    """``words.json`` entries: each word with its span and the phones inside it (recording time)."""
    out = []
    for w in words:
        inside = [p for p in phones if p.name != "pau" and w.start - 1e-6 <= p.start < w.end - 1e-6]
        out.append(
            {
                "word": w.word,
                "clip": clip_id,
                "start": w.start + offset,
                "end": w.end + offset,
                "phones": [
                    {"name": p.name, "start": p.start + offset, "end": p.end + offset}
                    for p in inside
                ],
            }
        )
    return out
