"""Clips of one person joined into one video, with the transcript and subtitles a user would have.

The tests and the one-video bench have no long recording of GRID's talker: they
make one. :func:`join_clips` decodes each clip, fits its sound to its frames,
and writes the clips one after the other as one mp4 (``joined.mp4``), with

``transcript.txt``
    the whole text, one sentence per clip, as a person would type it
    (capitalised, a full stop at the end);
``subtitles.srt``
    one cue per clip, from its first word's start to its last word's end
    in GRID's word timings (sentence cues, as published subtitles have);
``words.tsv``
    every word of GRID's timings in the joined video's time (the truth the
    aligned words are measured against);
``clips.tsv``
    where each clip starts and ends in the joined video.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.corpus.clips import write_table
from miketalk.media.atomic import write_text_atomic

#: Sound rate of the joined video.
RATE = 16000


@dataclass(frozen=True)
class Joined:
    """The files :func:`join_clips` wrote and where each clip is in the joined video."""

    video: Path
    transcript: Path
    subtitles: Path
    words: Path
    clips: Path
    spans: dict[str, tuple[float, float]]


def join_clips(
    ids: Sequence[str],
    out_dir: str | Path,
    *,
    media: str,
    transcripts: str | Path,
    timings: str,
    crf: int = 0,
) -> Joined:
    """Join the clips ``ids`` into one video with its transcript, subtitles and word truth.

    Parameters
    ----------
    ids : sequence of str
        The clips, in the order they are joined.
    out_dir : path
        Where the files go (created).
    media, timings : str
        Path patterns with ``{id}`` of a clip's video and its GRID ``.align`` file.
    transcripts : path
        The ``id text`` table.
    crf : int
        x264's constant rate factor of the joined video (0: lossless, so the
        joined frames are the clips' frames but for the chroma's round trip).
    """
    from miketalk.corpus.clip_sources import read_transcripts
    from miketalk.media.decode import read_media_audio, read_video
    from miketalk.media.video import write_mp4
    from miketalk.speech.word_timings import read_word_timings

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = read_transcripts(transcripts)
    audio, sentences, cues, words, rows = [], [], [], [], []
    spans: dict[str, tuple[float, float]] = {}
    fps = None
    n_total = 0
    for clip in ids:  # first the sound and the frame counts: the mp4's sound comes first
        clip_frames, clip_fps = read_video(media.replace("{id}", clip))
        fps = fps or clip_fps
        start, n = n_total / fps, len(clip_frames)
        del clip_frames  # a long join does not wait in memory
        samples = read_media_audio(media.replace("{id}", clip), rate=RATE)
        need = round(n / fps * RATE)
        samples = np.concatenate([samples, np.zeros(max(0, need - len(samples)), np.int16)])
        audio.append(samples[:need])
        text = table[clip]
        sentences.append(text[0].upper() + text[1:] + ".")
        timed = read_word_timings(timings.replace("{id}", clip))
        cues.append((start + timed[0].start, start + timed[-1].end, text))
        words += [(clip, w.word, f"{start + w.start:.5f}", f"{start + w.end:.5f}") for w in timed]
        spans[clip] = (start, start + n / fps)
        rows.append((clip, n_total, n, f"{start:.5f}", f"{n / fps:.5f}"))
        n_total += n
    video = out / "joined.mp4"
    write_mp4(
        video,
        (f for clip in ids for f in read_video(media.replace("{id}", clip))[0]),
        fps=fps,
        audio=np.concatenate(audio),
        rate=RATE,
        n_frames=n_total,
        crf=crf,
    )
    transcript = out / "transcript.txt"
    write_text_atomic(transcript, " ".join(sentences) + "\n")
    subtitles = out / "subtitles.srt"
    write_text_atomic(subtitles, _srt(cues))
    words_path, clips_path = out / "words.tsv", out / "clips.tsv"
    write_table(words_path, ("clip", "word", "start", "end"), words)
    write_table(clips_path, ("clip", "first_frame", "frames", "start", "duration"), rows)
    return Joined(video, transcript, subtitles, words_path, clips_path, spans)


def _srt(cues: Sequence[tuple[float, float, str]]) -> str:
    """SubRip text of ``(start, end, text)`` cues (written with the ``srt`` library)."""
    from datetime import timedelta

    import srt

    subtitles = [
        srt.Subtitle(index=i, start=timedelta(seconds=a), end=timedelta(seconds=b), content=t)
        for i, (a, b, t) in enumerate(cues, 1)
    ]
    return srt.compose(subtitles)
