"""How late a video's sound runs behind its mouth: measured in the evaluation alone (issue 52).

A video cut and re-encoded on its way to the user may carry its sound a few frames after the
picture. GRID's studio clips show the lips' opening and the sound's loudness together
(their pooled correlation peaks at 0 frames); the weekly addresses (the shared
``data/obama``) peak 2 frames later, both their AAC and their MP3 clips, though ffmpeg
decodes each stream at its container's time (the AAC's edit list starts at 0, the MP3's
skips its 1105 samples of priming): the lag is in the files.

:func:`sound_lag` measures it: the inner-lip opening over the eye distance of every frame
(dlib's 68 landmarks, :mod:`miketalk_lab.evaluation.landmarks`; the face found on every
:data:`DETECT_EVERY`-th frame at half size), against the log energy of the sound between
300 and 3000 Hz in each frame's time, over the given frames (at most
:data:`MAX_SECONDS`), correlated at every shift up to :data:`MAX_LAG_FRAMES` either way;
the peak is refined by a parabola. A lag is kept only where the data show one: a peak of r
at least :data:`MIN_PEAK_R`, inside the shifts searched, at least :data:`MIN_FRAMES` from
0, and the product's :data:`miketalk.corpus.sound_lag.APPLY` on (off); otherwise it is 0.
:func:`measure_sound_lag` measures a built model's training utterances
(``miketalk_lab.bench.anyone`` reports it per fold).

The 68-point predictor's training data (iBUG 300-W) is research-only, so the product never
measures this (``miketalk build`` did until then, in a ``sound lag`` stage; ``tests/
test_layout.py`` keeps the predictor out of ``src/miketalk``): the product only reads and
uses a lag a model records (:mod:`miketalk.corpus.sound_lag`).

``python -m miketalk_lab.evaluation.sound_sync VIDEO ...`` measures whole files over each
file's speech (the frames from the first to the last within 20 dB of its loud ones), and
prints each file's correlation at every shift and the pooled one (all files' pairs in one
correlation): the peak is how many frames the sound comes after the mouth.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.corpus import sound_lag as recorded
from miketalk.errors import MiketalkError

#: The largest lag searched, frames either way.
MAX_LAG_FRAMES = 4
#: The least correlation at the peak for a lag to be kept.
MIN_PEAK_R = 0.2
#: The least lag kept, frames: two of GRID's s1 clips alone peak at -0.83 (eight at -0.24),
#: what a few seconds of speech cannot tell from 0.
MIN_FRAMES = 1.0
#: Seconds of the utterances looked at, at most (the first ones).
MAX_SECONDS = 60.0
#: The face is found on every this many frames (the box kept in between).
DETECT_EVERY = 5
#: The sound's band (Hz) whose energy follows the mouth's opening.
BAND = (300.0, 3000.0)


@dataclass(frozen=True)
class SoundLag:
    """A video's sound against its mouth.

    Attributes
    ----------
    seconds : float
        How much later the sound comes than the mouth (0: none kept).
    peak_frames : float
        Where the correlation peaks, frames (refined), whether kept or not.
    peak_r : float
        The correlation there.
    curve : dict
        The correlation at each whole shift of frames.
    frames : int
        The frames measured.
    """

    seconds: float
    peak_frames: float
    peak_r: float
    curve: dict[int, float]
    frames: int


def sound_envelope(samples: np.ndarray, rate: int, fps: float, frames: int) -> np.ndarray:
    """The log energy of the sound in :data:`BAND` over each frame's time."""
    from scipy.signal import butter, sosfiltfilt

    sos = butter(4, BAND, btype="band", fs=rate, output="sos")
    x = np.asarray(samples, float)
    x = sosfiltfilt(sos, x) if len(x) > 30 else np.zeros(len(x))
    total = np.concatenate([[0.0], np.cumsum(x * x)])
    edges = np.clip(np.round(np.arange(frames + 1) * rate / fps).astype(int), 0, len(x))
    energy = (total[edges[1:]] - total[edges[:-1]]) / np.maximum(np.diff(edges), 1)
    return np.log(energy + 1.0)


def lag_of_curves(
    openings: Sequence[np.ndarray], envelopes: Sequence[np.ndarray], fps: float
) -> SoundLag:
    """The lag of the sound behind the mouth over utterances (each its openings and its
    sound's envelope, frame by frame; NaN openings left out), pooled: at each shift the
    pairs of every utterance in one correlation."""
    curve: dict[int, float] = {}
    for lag in range(-MAX_LAG_FRAMES, MAX_LAG_FRAMES + 1):
        xs, ys = [], []
        for o, e in zip(openings, envelopes, strict=True):
            n = min(len(o), len(e))
            k = np.arange(max(0, -lag), min(n, n - lag))
            keep = np.isfinite(o[k])
            xs.append(e[k[keep] + lag])
            ys.append(o[k[keep]])
        x, y = np.concatenate(xs or [[]]), np.concatenate(ys or [[]])
        ok = len(x) > 10 and x.std() > 0 and y.std() > 0
        curve[lag] = float(np.corrcoef(x, y)[0, 1]) if ok else 0.0
    best = max(curve, key=lambda k: (curve[k], -abs(k)))
    peak = float(best)
    if abs(best) < MAX_LAG_FRAMES:
        a, b, c = curve[best - 1], curve[best], curve[best + 1]
        bend = a - 2 * b + c
        peak = best + (0.5 * (a - c) / bend if bend < 0 else 0.0)
    kept = curve[best] >= MIN_PEAK_R and abs(best) < MAX_LAG_FRAMES and abs(peak) >= MIN_FRAMES
    kept = kept and recorded.APPLY
    frames = int(sum(np.isfinite(o).sum() for o in openings))
    return SoundLag(peak / fps if kept else 0.0, peak, curve[best], curve, frames)


def mouth_openings(video: Path, start: int, count: int) -> np.ndarray:
    """The inner-lip opening over the eye distance of frames ``start`` to ``start + count``
    (NaN where no face is found; the face box found on every :data:`DETECT_EVERY`-th frame,
    at half size when wider than 640, and kept in between)."""
    import cv2

    from miketalk.media.decode import iter_video_frames, video_info
    from miketalk_lab.evaluation.landmarks import EYES, face_landmarks, lip_opening

    fps = video_info(video)[2]
    marker = face_landmarks()
    out = np.full(count, np.nan)
    box = None
    frames = iter_video_frames(video, grey=True, start=start / fps, frames=count)
    for k, frame in enumerate(frames):
        if k % DETECT_EVERY == 0:
            scale = 2 if frame.shape[1] > 640 else 1
            small = cv2.resize(frame, None, fx=1 / scale, fy=1 / scale,
                               interpolation=cv2.INTER_AREA)  # fmt: skip
            found = marker.detect(small)
            box = None if found is None else tuple(int(v * scale) for v in found)
        if box is None:
            continue
        p = marker.points(frame[None], box)
        eyes = np.linalg.norm(p[0, EYES[0]].mean(axis=0) - p[0, EYES[1]].mean(axis=0))
        out[k] = lip_opening(p)[0] / eyes if eyes > 0 else np.nan
    return out


def sound_lag(video: str | Path, spans: Sequence[tuple[int, int]]) -> SoundLag:
    """The lag of ``video``'s sound behind its mouth over its frames ``spans`` (each
    ``(first frame, frames)``; the first :data:`MAX_SECONDS` of them), see the module
    docstring."""
    from miketalk.media.decode import read_media_audio, video_info

    video = Path(video)
    fps = video_info(video)[2]
    rate = 16000
    openings, envelopes, left = [], [], MAX_SECONDS * fps
    for first, count in spans:
        count = int(min(count, left))
        if count < 3:
            break
        left -= count
        openings.append(mouth_openings(video, first, count))
        sound = read_media_audio(video, rate=rate, start=first / fps, duration=count / fps)
        envelopes.append(sound_envelope(sound, rate, fps, count))
    return lag_of_curves(openings, envelopes, fps)  # none to measure on: no lag, 0 frames


def measure_sound_lag(video: str | Path, segments: str | Path) -> SoundLag:
    """The lag of ``video``'s sound over the training utterances of ``segments`` (a
    ``segments.json``: a built model's ``build/segments.json``, whose frames are
    ``video``'s)."""
    doc = json.loads(Path(segments).read_text("utf-8"))
    spans = [(u["first_frame"], u["frames"]) for u in doc["utterances"] if u["split"] == "train"]
    return sound_lag(video, spans)


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
