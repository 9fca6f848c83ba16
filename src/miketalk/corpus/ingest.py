"""A person's corpus recording, brought into the layout the workflow reads.

The synthetic subject writes its corpus with :func:`synth_face.recording.record_corpus`;
a person's mp4 (with audio) of the same words goes through :func:`ingest_video`,
which writes the same files, minus the hidden truth (``truth.tsv`` has only its
header, and the metrics that need truth are skipped).
"""

from __future__ import annotations

import logging
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

import cv2
import imageio_ffmpeg
import numpy as np

from miketalk.corpus.folder import (
    AUDIO,
    FRAMES,
    FRAMES_TABLE,
    TRUTH,
    VIDEO,
    WORDS,
    empty_truth_text,
    frame_path,
    frames_table_text,
    words_doc,
)
from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_path, write_text_atomic
from miketalk.media.audio import read_wav, write_wav
from miketalk.media.images import write_png
from miketalk.speech.backend import SpeechBackend

log = logging.getLogger(__name__)

#: Frames wider than this get a hint to crop and scale (flow and morph time grow with pixels).
LARGE_WIDTH = 640


def ingest_video(
    video: str | Path,
    out_dir: str | Path,
    *,
    words: list[str],
    backend: SpeechBackend,
    crop: Sequence[int] | None = None,
    width: int | None = None,
) -> Path:
    """Decode ``video`` into ``out_dir``: frames, 16 kHz mono audio, word list, tables.

    Parameters
    ----------
    video, out_dir : path
        The recording (mp4 with sound) and the corpus directory to fill.
    words : list of str
        The corpus words, in the order they are spoken.
    backend : SpeechBackend
        Festival, for each word's predicted phones.
    crop : sequence of 4 int, optional
        ``(x, y, width, height)`` in the recording's pixels: the part of every
        frame to keep (the mouth and what moves with it). Default: all of it.
    width : int, optional
        Scale the (cropped) frames to this width, area-averaged when shrinking;
        the height keeps the aspect ratio, rounded to an even number. Default:
        no scaling.

    Raises
    ------
    MiketalkError
        If the video is missing, unreadable, or has no audio track, or ``crop``
        or ``width`` do not fit it.
    """
    video, out = Path(video), Path(out_dir)
    if not video.exists():
        raise MiketalkError(f"corpus video {video} does not exist")
    try:
        reader = imageio_ffmpeg.read_frames(str(video), pix_fmt="rgb24")
        meta = next(reader)
    except (OSError, RuntimeError, StopIteration) as err:
        raise MiketalkError(f"cannot read corpus video {video}: {err}") from err
    source_w, source_h = meta["size"]
    fps = float(meta["fps"])
    rows, cols = _crop_slices(crop, source_w, source_h)
    crop_w, crop_h = cols.stop - cols.start, rows.stop - rows.start
    size = _scaled_size(width, crop_w, crop_h)
    if size[0] > LARGE_WIDTH:
        log.warning(
            "corpus frames are %dx%d: flow and morph time grow with the pixel count; "
            "set corpus.video_crop to the mouth region and corpus.video_width (e.g. 256)",
            *size,
        )
    frames_dir = out / FRAMES
    frames_dir.mkdir(parents=True, exist_ok=True)
    n = 0
    for raw in reader:
        frame = np.frombuffer(raw, np.uint8).reshape(source_h, source_w, 3)[rows, cols]
        if size != (crop_w, crop_h):
            shrink = size[0] < crop_w
            frame = cv2.resize(
                frame, size, interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
            )
        write_png(frame_path(frames_dir, n), np.ascontiguousarray(frame))
        n += 1
    if n < 3:
        raise MiketalkError(f"corpus video {video} has {n} frames")
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "audio.wav"
        proc = subprocess.run(
            [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(video), "-vn",
             "-ac", "1", "-ar", "16000", "-c:a", "pcm_s16le", str(wav)],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        if proc.returncode != 0 or not wav.exists():
            raise MiketalkError(f"corpus video {video} has no readable audio track")
        samples, rate = read_wav(wav)
    write_wav(out / AUDIO, samples, rate)
    predicted = backend.synthesize_each(words)
    spoken = [
        {"word": w, "phones": [{"name": p.name, "start": p.start, "end": p.end} for p in u.phones]}
        for w, u in zip(words, predicted, strict=True)
    ]
    doc = words_doc(fps=fps, size=[size[1], size[0]], rate=rate, source=str(video), words=spoken)
    write_text_atomic(out / WORDS, doc)
    write_text_atomic(out / FRAMES_TABLE, frames_table_text(n, fps))
    write_text_atomic(out / TRUTH, empty_truth_text())
    with atomic_path(out / VIDEO) as tmp:
        shutil.copyfile(video, tmp)
    return out


def _crop_slices(crop: Sequence[int] | None, width: int, height: int) -> tuple[slice, slice]:
    """Row and column slices of ``crop`` = (x, y, w, h) in a ``width`` x ``height`` frame."""
    if crop is None:
        return slice(0, height), slice(0, width)
    values = list(crop)
    if len(values) != 4 or not all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        raise MiketalkError(
            f"corpus.video_crop must be four integers [x, y, width, height], not {crop!r}"
        )
    x, y, w, h = values
    if x < 0 or y < 0 or w < 16 or h < 16 or x + w > width or y + h > height:
        raise MiketalkError(
            f"corpus.video_crop {values} does not fit the {width}x{height} recording "
            "(x, y >= 0; width, height >= 16; inside the frame)"
        )
    return slice(y, y + h), slice(x, x + w)


def _scaled_size(width: int | None, crop_w: int, crop_h: int) -> tuple[int, int]:
    """(width, height) of the frames written: ``width`` wide, even height, same aspect."""
    if width is None:
        return crop_w, crop_h
    if isinstance(width, bool) or not isinstance(width, int) or width < 16:
        raise MiketalkError(f"corpus.video_width must be an integer >= 16, not {width!r}")
    height = max(2, 2 * round(crop_h * width / crop_w / 2))
    return width, height
