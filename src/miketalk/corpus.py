"""A person's corpus recording, brought into the layout the workflow reads.

The synthetic subject writes its corpus with :func:`synth_face.recording.record_corpus`;
a person's mp4 (with audio) of the same words goes through :func:`ingest_video`,
which writes the same files, minus the hidden truth (``truth.tsv`` has only its
header, and the metrics that need truth are skipped).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
from pathlib import Path

import imageio_ffmpeg
import numpy as np

from miketalk.atomic import atomic_path, write_text_atomic
from miketalk.audio import read_wav, write_wav
from miketalk.errors import MiketalkError
from miketalk.images import write_png
from miketalk.speech.festival import FestivalBackend


def ingest_video(
    video: str | Path, out_dir: str | Path, *, words: list[str], backend: FestivalBackend
) -> Path:
    """Decode ``video`` into ``out_dir``: frames, 16 kHz mono audio, word list, tables.

    Raises
    ------
    MiketalkError
        If the video is missing, unreadable, or has no audio track.
    """
    video, out = Path(video), Path(out_dir)
    if not video.exists():
        raise MiketalkError(f"corpus video {video} does not exist")
    try:
        reader = imageio_ffmpeg.read_frames(str(video), pix_fmt="rgb24")
        meta = next(reader)
    except (OSError, RuntimeError, StopIteration) as err:
        raise MiketalkError(f"cannot read corpus video {video}: {err}") from err
    width, height = meta["size"]
    fps = float(meta["fps"])
    frames_dir = out / "frames"
    frames_dir.mkdir(parents=True, exist_ok=True)
    n = 0
    for raw in reader:
        frame = np.frombuffer(raw, np.uint8).reshape(height, width, 3)
        write_png(frames_dir / f"{n:06d}.png", frame)
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
    write_wav(out / "audio.wav", samples, rate)
    predicted = backend.synthesize_each(words)
    doc = {
        "fps": fps,
        "size": [height, width],
        "rate": rate,
        "source": str(video),
        "words": [
            {
                "word": w,
                "phones": [{"name": p.name, "start": p.start, "end": p.end} for p in u.phones],
            }
            for w, u in zip(words, predicted, strict=True)
        ],
    }
    write_text_atomic(out / "words.json", json.dumps(doc, indent=1))
    write_text_atomic(
        out / "frames.tsv", "frame\ttime\n" + "".join(f"{k}\t{k / fps:.6f}\n" for k in range(n))
    )
    write_text_atomic(out / "truth.tsv", "key\tword\tphone\ttime\tframe\n")
    with atomic_path(out / "corpus.mp4") as tmp:
        shutil.copyfile(video, tmp)
    return out
