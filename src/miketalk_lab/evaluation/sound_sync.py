"""How late each video's sound runs behind its mouth, per file and pooled (issue 52's timing).

``python -m miketalk_lab.evaluation.sound_sync VIDEO ...`` measures what a build measures
(:mod:`miketalk.corpus.sound_lag`: the lips' opening over the eye distance, dlib's 68
points, against the sound's 300-3000 Hz log energy, frame by frame) on whole files, over
each file's speech (the frames from the first to the last within 20 dB of its loud ones),
and prints each file's correlation at every shift and the pooled one (all files' pairs in
one correlation): the peak is how many frames the sound comes after the mouth.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError


def speech_span(audio: np.ndarray, rate: int, fps: float, frames: int) -> slice:
    """The frames from the first to the last whose sound (RMS over the frame) is within
    20 dB of the clip's loud frames (its 90th percentile)."""
    per = rate / fps
    rms = np.array(
        [
            np.sqrt(np.mean(audio[round(k * per) : round((k + 1) * per)].astype(float) ** 2) + 1e-9)
            for k in range(frames)
        ]
    )
    loud = np.flatnonzero(rms >= np.percentile(rms, 90) / 10)
    if not len(loud):
        raise MiketalkError("no speech found in the clip's sound")
    return slice(int(loud[0]), int(loud[-1]) + 1)


def file_curves(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """A file's openings and sound envelope over its speech, and its frame rate."""
    from miketalk.corpus.sound_lag import mouth_openings, sound_envelope
    from miketalk.media.decode import read_media_audio, video_info

    fps = video_info(path)[2]
    rate = 16000
    sound = read_media_audio(path, rate=rate)
    frames = int(len(sound) / rate * fps)
    speech = speech_span(sound, rate, fps, frames)
    openings = mouth_openings(path, 0, frames)[speech]
    return openings, sound_envelope(sound, rate, fps, frames)[speech], fps


def main(argv: list[str] | None = None) -> int:
    """The command line (the module docstring)."""
    from miketalk.corpus.sound_lag import lag_of_curves

    parser = argparse.ArgumentParser(prog="python -m miketalk_lab.evaluation.sound_sync")
    parser.add_argument("videos", nargs="+", type=Path)
    args = parser.parse_args(argv)
    openings, envelopes = [], []
    for path in args.videos:
        o, e, fps = file_curves(path)
        got = lag_of_curves([o], [e], fps)
        curve = " ".join(f"{k:+d}:{v:.2f}" for k, v in got.curve.items())
        print(f"{path.stem}: peak {got.peak_frames:+.2f} frames (r {got.peak_r:.2f}) {curve}")
        openings.append(o)
        envelopes.append(e)
    pooled = lag_of_curves(openings, envelopes, fps)
    curve = " ".join(f"{k:+d}:{v:.2f}" for k, v in pooled.curve.items())
    print(f"pooled ({len(openings)} files, {pooled.frames} frames): peak "
          f"{pooled.peak_frames:+.2f} frames (r {pooled.peak_r:.2f}), kept "
          f"{pooled.seconds * 1000:.0f} ms; {curve}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
