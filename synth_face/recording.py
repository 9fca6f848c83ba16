"""The synthetic subject records the paper's corpus (Figure 3) on video.

The face speaks the corpus words in order, each timed by Festival's phones for
that word, with the silence pose held in the pauses between words. Each phone
puts a keyframe at its middle (a diphthong one per nucleus, at a quarter and
three quarters of it, as :mod:`miketalk.lipsync.timeline` does); the word's target
phone takes the corpus target's pose (``o`` for the ``aa`` of "body", ``e@:1``
and ``e@:2`` for the ``eh`` and ``r`` of "there"). Between keyframes the mouth
parameters follow a smoothstep, so the mouth comes to rest at each target: the
lips are at their extremal position there, as the paper's subject's were.

Written to the output directory:

``frames/000000.png ...``  the video frames
``frames.tsv``             frame, time, word, phone, then every mouth parameter
``audio.wav``              the recording's sound (Festival's words, in order)
``corpus.mp4``             frames + audio, as a camera would give them
``words.json``             the word list and Festival's predicted phones per word,
                           times relative to the word's own synthesis: what a
                           real recording session also has
``truth.tsv``              hidden ground truth: each corpus target's keyframe
                           time and peak frame (closest to its target pose)
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from queue import Full, Queue

import numpy as np

from miketalk.corpus.folder import (
    AUDIO,
    FRAMES,
    FRAMES_TABLE,
    TRUTH,
    TRUTH_COLUMNS,
    VIDEO,
    WORDS,
    frame_path,
    words_doc,
)
from miketalk.media.atomic import write_text_atomic
from miketalk.media.audio import write_wav
from miketalk.media.images import write_png
from miketalk.media.video import write_mp4
from miketalk.speech.backend import SpeechBackend
from miketalk.speech.types import Utterance
from miketalk.visemes import CorpusTarget, VisemeTable
from synth_face import Face, FaceRenderer

_FRACTIONS = {1: (0.5,), 2: (0.25, 0.75)}


@dataclass(frozen=True)
class Pose:
    """A keyframe of the recording: the mouth at ``params`` at ``time``."""

    time: float
    params: np.ndarray
    word: str
    phone: str
    target: str  # corpus target key, or "" for a phone that is not the word's target


def word_poses(
    word: str, utterance: Utterance, offset: float, face: Face, targets: list[CorpusTarget]
) -> list[Pose]:
    """Keyframes for one spoken word whose audio starts at ``offset`` seconds."""
    spoken = [p.name for p in utterance.phones if p.name != "pau"]
    for t in targets:
        if tuple(spoken) != t.phones:
            raise ValueError(
                f"Festival says {word!r} as {' '.join(spoken)}, the corpus table expects "
                f"{' '.join(t.phones)} (target {t.key})"
            )
    poses = []
    position = -1
    for phone in utterance.phones:
        if phone.name != "pau":
            position += 1
        nuclei = list(face.phone_targets(phone.name))
        keys = [""] * len(nuclei)
        here = [t for t in targets if t.position == position and phone.name != "pau"]
        if len(here) == 2:  # both nuclei of a diphthong phone ("boat")
            here.sort(key=lambda t: t.nucleus)
            nuclei, keys = [face.target(t.key) for t in here], [t.key for t in here]
        elif len(here) == 1:  # a consonant, a monophthong, or one nucleus ("there")
            nuclei, keys = [face.target(here[0].key)], [here[0].key]
        for params, f, key in zip(nuclei, _FRACTIONS[len(nuclei)], keys, strict=True):
            t = offset + phone.start + f * phone.duration
            if phone.name == "pau":
                params = face.target("#")
            poses.append(Pose(t, np.asarray(params, dtype=np.float64), word, phone.name, key))
    return poses


def trajectory(poses: list[Pose], times: np.ndarray) -> np.ndarray:
    """Mouth parameters at ``times``: smoothstep between consecutive keyframes."""
    key_t = np.array([p.time for p in poses])
    key_p = np.stack([p.params for p in poses])
    i = np.clip(np.searchsorted(key_t, times, side="right") - 1, 0, len(poses) - 2)
    span = key_t[i + 1] - key_t[i]
    s = np.clip((times - key_t[i]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
    s = s * s * (3.0 - 2.0 * s)
    out = key_p[i] + s[:, None] * (key_p[i + 1] - key_p[i])
    out[times <= key_t[0]] = key_p[0]
    out[times >= key_t[-1]] = key_p[-1]
    return out


def record_corpus(
    out_dir: str | Path,
    *,
    backend: SpeechBackend,
    table: VisemeTable,
    size: int = 256,
    fps: float = 30.0,
    words: list[str] | None = None,
) -> Path:
    """Render the synthetic subject speaking the corpus words; see the module docstring.

    Parameters
    ----------
    out_dir : path
        Directory to fill (created; files are replaced atomically).
    backend : SpeechBackend
        Festival: the timing and audio of each word.
    table : VisemeTable
        The corpus targets.
    size : int
        Frame width and height in pixels.
    fps : float
        Frame rate.
    words : list of str, optional
        A subset of the corpus words, in order (for small test corpora).

    Returns
    -------
    pathlib.Path
        ``out_dir``.
    """
    out = Path(out_dir)
    face = Face()
    all_words = table.corpus_words()
    words = all_words if words is None else [w for w in all_words if w in set(words)]
    poses: list[Pose] = []
    audio: list[np.ndarray] = []
    predicted = []
    offset_samples, rate = 0, 16000
    spoken = backend.synthesize_each(words)
    for word, utt in zip(words, spoken, strict=True):
        rate = utt.rate
        targets = [t for t in table.targets if t.word == word]
        poses += word_poses(word, utt, offset_samples / rate, face, targets)
        predicted.append(
            {
                "word": word,
                "phones": [{"name": p.name, "start": p.start, "end": p.end} for p in utt.phones],
            }
        )
        audio.append(utt.samples)
        offset_samples += len(utt.samples)
    samples = np.concatenate(audio)
    duration = len(samples) / rate
    n_frames = max(1, round(duration * fps))
    times = np.arange(n_frames) / fps
    params = trajectory(poses, times)

    frames_dir = out / FRAMES
    frames_dir.mkdir(parents=True, exist_ok=True)
    _render_frames(face, size, params, frames_dir, out / VIDEO, fps, samples, rate)

    key_t = np.array([p.time for p in poses])
    which = np.clip(np.searchsorted(key_t, times, side="right") - 1, 0, len(poses) - 1)
    buf = io.StringIO()
    writer = csv.writer(buf, delimiter="\t", lineterminator="\n")
    writer.writerow(["frame", "time", "word", "phone", *face.param_names])
    for k in range(n_frames):
        pose = poses[which[k]]
        word = pose.word if pose.phone != "pau" else "-"
        writer.writerow([k, f"{times[k]:.6f}", word, pose.phone, *(f"{v:.6f}" for v in params[k])])
    write_text_atomic(out / FRAMES_TABLE, buf.getvalue())

    buf = io.StringIO()
    writer = csv.writer(buf, delimiter="\t", lineterminator="\n")
    writer.writerow(TRUTH_COLUMNS)
    silence = _silence_truth(poses, words)
    for pose in poses:
        if not pose.target:
            continue
        # the peak: the frame nearest in time whose pose is closest to the target
        distance = np.linalg.norm(params - pose.params, axis=1)
        near = np.flatnonzero(np.abs(times - pose.time) <= 0.1)
        order = np.lexsort((np.abs(times[near] - pose.time), np.round(distance[near], 9)))
        frame = int(near[order[0]])
        writer.writerow([pose.target, pose.word, pose.phone, f"{pose.time:.6f}", frame])
    for pose, (start, end) in silence:
        # held still from one pause keyframe to the next: frames whose neighbours
        # are both inside the hold are identical; the truth is the middle one
        first, last = int(np.ceil(start * fps)) + 1, int(np.floor(end * fps)) - 1
        frame = min(n_frames - 1, (first + last) // 2)
        writer.writerow([pose.target, pose.word, pose.phone, f"{frame / fps:.6f}", frame])
    write_text_atomic(out / TRUTH, buf.getvalue())
    write_text_atomic(out / WORDS, words_doc(fps=fps, size=size, rate=rate, words=predicted))
    write_wav(out / AUDIO, samples, rate)
    return out


def _render_frames(
    face: Face,
    size: int,
    params: np.ndarray,
    frames_dir: Path,
    video: Path,
    fps: float,
    samples: np.ndarray,
    rate: int,
) -> None:
    """Render every frame to ``frames_dir`` as PNG and to ``video`` as mp4.

    The renderer holds this thread; the PNG writes (OpenCV releases the GIL)
    and the mp4 (fed through a queue to ffmpeg) run in two more threads, so
    they overlap with rendering instead of following it.
    """
    queue: Queue[np.ndarray | None] = Queue(maxsize=64)

    def stream() -> Iterator[np.ndarray]:
        while (frame := queue.get()) is not None:
            yield frame

    with ThreadPoolExecutor(2, thread_name_prefix="corpus-out") as pool:
        encoded = pool.submit(
            write_mp4, video, stream(), fps=fps, audio=samples, rate=rate, n_frames=len(params)
        )  # fmt: skip

        def feed(item: np.ndarray | None) -> bool:
            """Queue ``item`` for ffmpeg; False once the encoder has stopped (failed)."""
            while not encoded.done():
                try:
                    queue.put(item, timeout=0.2)
                    return True
                except Full:
                    pass
            return False

        writes = []
        renderer = FaceRenderer(face, size=size)
        try:
            for k, p in enumerate(params):
                image = renderer.render(p)
                writes.append(pool.submit(write_png, frame_path(frames_dir, k), image))
                if not feed(image):
                    break
                if len(writes) > 64:  # keep at most this many frames waiting
                    writes.pop(0).result()
        finally:
            renderer.close()
            feed(None)
        for write in writes:
            write.result()
        encoded.result()


def _silence_truth(poses: list[Pose], words: list[str]) -> list[tuple[Pose, tuple[float, float]]]:
    """The silence target and the span it is held: the first pause between two words."""
    pauses = [p for p in poses if p.phone == "pau"]
    if len(words) > 1:
        # the first word's trailing pause and the second word's leading one
        first_end = next(i for i, p in enumerate(pauses) if p.word == words[1]) - 1
        a, b = pauses[first_end], pauses[first_end + 1]
    else:
        a = b = pauses[0]
    return [(Pose(0.5 * (a.time + b.time), a.params, "-", "pau", "#"), (a.time, b.time))]
