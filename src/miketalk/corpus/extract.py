"""Viseme extraction (paper §4): find each corpus target's frame in a recording.

The paper chose by hand "the image where the lips are at their extremal
position". Here it is automatic and uses only what a real recording gives: the
video, its audio, the word list, and Festival's predicted timing of each word.

1. Words are located in the audio (one speech segment per word) and Festival's
   synthesis of each word is aligned to it (:mod:`miketalk.speech.audio_align`), so each
   target's predicted time (its phone's middle; a diphthong's nuclei at a
   quarter and three quarters) maps into the recording.
2. The mouth is found as the part of the picture that moves most over the
   recording, and its motion energy per frame is the mean absolute central
   difference ``|I[k+1] - I[k-1]|`` there.
3. The lips are at an extremal position where they stop: the target's frame
   minimises the motion energy (normalised over a window of half the distance
   to the neighbouring phones' keyframes) plus a charge for frames away from
   the predicted time, which settles the ties of lips resting still.
4. The silence target is the stillest frame in the middle of the first pause.

The 52 targets are then reduced to the configured visemes: each viseme's image
is the frame of its representative target (:meth:`VisemeTable.representative`).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from miketalk.corpus.folder import TRUTH, CorpusVideo, open_corpus
from miketalk.corpus.rest import grey_stack, motion_region
from miketalk.errors import MiketalkError
from miketalk.media.audio import read_wav
from miketalk.speech.audio_align import locate_words, map_times
from miketalk.speech.backend import SpeechBackend, get_backend
from miketalk.visemes import VisemeTable

_FRACTIONS = {0: 0.5, 1: 0.25, 2: 0.75}


def motion_energy(
    video: CorpusVideo, *, scale: int = 2, block: int = 1024
) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame mouth motion energy and the region it was measured in.

    The frames are read as grey uint8 at ``1 / scale`` of their size and measured
    ``block`` frames at a time, so that a long recording is held once.

    Returns
    -------
    energy : (n_frames,) float64
        Mean absolute central difference of grey levels in the region.
    region : (H // scale, W // scale) bool
        The pixels that vary most over the recording (the mouth and jaw).
    """
    paths = list(video.frame_paths)
    if len(paths) < 3:
        raise MiketalkError(f"{video.directory} has {len(paths)} frames; a recording needs more")

    def read(path) -> np.ndarray:
        g = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if g is None:
            raise MiketalkError(f"cannot read frame {path}")
        return cv2.resize(g, None, fx=1 / scale, fy=1 / scale, interpolation=cv2.INTER_AREA)

    stack = grey_stack(map(read, paths), len(paths))  # uint8: a long recording held once
    region = motion_region(stack)
    diff = np.concatenate(
        [
            np.abs(
                stack[k + 2 : end + 2, region].astype(np.float32)
                - stack[k:end, region].astype(np.float32)
            ).mean(axis=1)
            for k in range(0, len(stack) - 2, block)
            for end in [min(k + block, len(stack) - 2)]
        ]
    )
    energy = np.concatenate([[diff[0]], diff, [diff[-1]]]).astype(np.float64)
    return energy, region


def _stillest(
    energy: np.ndarray, fps: float, t: float, half_width: float, *, time_weight: float = 1.0
) -> int:
    """The frame where the lips stop, near the predicted time ``t``.

    Within ``half_width`` seconds of ``t``, minimise ``e(k) / max(e) + w (k - t F)^2``:
    the motion energy normalised over the window, plus a charge for each frame
    away from the time the audio predicts (``w = time_weight`` per frame
    squared). Motion alone is ambiguous when the lips rest for several frames
    (closed lips for b, p, m); the audio's time settles those ties.
    """
    n = len(energy)
    lo = max(0, int(np.ceil((t - half_width) * fps)))
    hi = min(n - 1, int(np.floor((t + half_width) * fps)))
    if hi < lo:
        return int(np.clip(round(t * fps), 0, n - 1))
    frames = np.arange(lo, hi + 1)
    e = energy[frames]
    score = e / max(float(e.max()), 1e-12) + time_weight * (frames - t * fps) ** 2
    return int(frames[np.argmin(score)])


def extract_targets(video: CorpusVideo, table: VisemeTable, backend: SpeechBackend) -> pd.DataFrame:
    """Find every corpus target of the recorded words; see the module docstring.

    Returns
    -------
    pandas.DataFrame
        One row per target: key, viseme, word, phone, time (seconds in the
        recording), frame.
    """
    samples, rate = read_wav(video.audio_path)
    segments = locate_words(samples, rate, len(video.words))
    predicted = backend.synthesize_each(video.words)
    energy, _ = motion_energy(video)
    rows = []
    margin = 0.1
    for word, segment, utt in zip(video.words, segments, predicted, strict=True):
        speech = [p for p in utt.phones if p.name != "pau"]
        ps, pe = max(0.0, speech[0].start - margin), speech[-1].end + margin
        rs, re_ = max(0.0, segment.start - margin), segment.end + margin
        to_recorded = map_times(
            utt.samples[round(ps * utt.rate) : round(pe * utt.rate)],
            utt.rate,
            samples[round(rs * rate) : round(re_ * rate)],
            rate,
        )
        # every keyframe of the word, predicted then mapped into the recording
        keys = []
        for i, phone in enumerate(speech):
            n = len(table.visemes_of(phone.name))
            for nucleus in (0,) if n == 1 else (1, 2):
                t = phone.start + _FRACTIONS[nucleus] * phone.duration
                keys.append((i, nucleus, rs + float(to_recorded(t - ps))))
        key_times = np.array([k[2] for k in keys])
        for target in (t for t in table.targets if t.word == word):
            nucleus = target.nucleus if len(table.visemes_of(target.phone)) == 2 else 0
            j = next(j for j, k in enumerate(keys) if k[:2] == (target.position, nucleus))
            t = key_times[j]
            gaps = np.abs(np.delete(key_times, j) - t)
            half = max(0.5 * gaps.min() if gaps.size else 0.1, 1.0 / video.fps)
            frame = _stillest(energy, video.fps, t, half)
            rows.append(
                dict(key=target.key, viseme=target.viseme, word=word, phone=target.phone,
                     time=t, frame=frame)
            )  # fmt: skip
    silence = next(t for t in table.targets if t.klass == "silence")
    a, b = (segments[0].end, segments[1].start) if len(segments) > 1 else (0.0, segments[0].start)
    frame = _still_middle(energy, video.fps, a, b)
    rows.append(
        dict(key=silence.key, viseme=silence.viseme, word="-", phone="pau",
             time=frame / video.fps, frame=frame)
    )  # fmt: skip
    return pd.DataFrame(rows)


def _still_middle(energy: np.ndarray, fps: float, start: float, end: float) -> int:
    """The middle of the longest still run of frames in a pause ``[start, end]`` s.

    Still: motion energy within 5% of the pause's range above its minimum.
    """
    lo = max(0, int(np.ceil(start * fps)))
    hi = min(len(energy) - 1, int(np.floor(end * fps)))
    if hi <= lo:
        return int(np.clip(round(0.5 * (start + end) * fps), 0, len(energy) - 1))
    e = energy[lo : hi + 1]
    still = e <= e.min() + 0.05 * (e.max() - e.min())
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(np.int8), [0]])))
    runs = list(zip(edges[::2], edges[1::2], strict=True))
    first, last = max(runs, key=lambda r: (r[1] - r[0], -r[0]))
    return lo + (first + last - 1) // 2


def select_visemes(targets: pd.DataFrame, table: VisemeTable) -> pd.DataFrame:
    """Reduce the extracted targets to one frame per viseme (its representative's).

    Raises
    ------
    MiketalkError
        If a viseme's representative target was not found in the recording.
    """
    rows = []
    by_key = targets.set_index("key")
    for viseme in table.visemes:
        key = table.representative(viseme).key
        if key not in by_key.index:
            raise MiketalkError(
                f"viseme {viseme!r} needs corpus target {key!r} "
                f"({table.representative(viseme).word!r}), which the recording lacks"
            )
        rows.append({"viseme": viseme, "key": key, "frame": int(by_key.loc[key, "frame"])})
    return pd.DataFrame(rows)


def read_frames_table(path: str | Path) -> dict[str, int]:
    """A hand-made ``key<TAB>frame`` table of viseme frames (overrides extraction)."""
    try:
        table = pd.read_csv(path, sep="\t", dtype={"key": str, "frame": int})
    except (OSError, ValueError) as err:
        raise MiketalkError(f"cannot read frames table {path}: {err}") from err
    if not {"key", "frame"} <= set(table.columns):
        raise MiketalkError(f"frames table {path} needs the columns key and frame")
    return dict(zip(table["key"], table["frame"], strict=True))


def extract_visemes_stage(
    *, corpus_dir: Path, grouping: dict, frames_table: str | None, out: object
) -> None:
    """The ``visemes`` rule: targets table, viseme images, contact sheet, word strip.

    ``out`` has the rule's named outputs: ``targets``, ``visemes``, ``images``,
    ``sheet``, ``strip``.
    """
    from miketalk.media.atomic import write_text_atomic
    from miketalk.media.images import write_png
    from miketalk.media.sheets import grid
    from miketalk.visemes import viseme_slug

    table = VisemeTable(grouping=grouping)
    video = open_corpus(corpus_dir)
    n_frames = video.n_frames
    targets = extract_targets(video, table, get_backend())
    targets["source"] = "extracted"
    if frames_table:
        for key, frame in read_frames_table(frames_table).items():
            if key not in set(targets["key"]):
                raise MiketalkError(f"frames table names {key!r}, not a target of this corpus")
            if not 0 <= frame < n_frames:
                raise MiketalkError(
                    f"frames table: frame {frame} of {key!r} is outside 0..{n_frames - 1}"
                )
            targets.loc[targets["key"] == key, ["frame", "source"]] = [frame, "table"]
    truth = pd.read_csv(corpus_dir / TRUTH, sep="\t", dtype={"key": str})
    if len(truth):
        targets = targets.merge(
            truth[["key", "frame"]].rename(columns={"frame": "true_frame"}), on="key", how="left"
        )
        targets["error"] = targets["frame"] - targets["true_frame"]
    else:
        targets["true_frame"] = pd.NA
        targets["error"] = pd.NA
    write_text_atomic(out.targets, targets.to_csv(sep="\t", index=False, float_format="%.4f"))

    chosen = select_visemes(targets, table)
    chosen = chosen.merge(targets[["key", "true_frame", "error"]], on="key", how="left")
    images_dir = Path(out.images)
    images_dir.mkdir(parents=True, exist_ok=True)
    images, paths = [], []
    for row in chosen.itertuples():
        image = video.frame(int(row.frame))
        images.append(image)
        path = images_dir / f"{viseme_slug(row.viseme)}.png"
        write_png(path, image)
        paths.append(path.name)
    chosen["image"] = paths
    write_text_atomic(out.visemes, chosen.to_csv(sep="\t", index=False))
    labels = [
        f"{r.viseme} ({r.key}) f{r.frame}" + ("" if pd.isna(r.error) else f" err {int(r.error):+d}")
        for r in chosen.itertuples()
    ]
    write_png(out.sheet, grid(images, labels, cols=4))
    # one corpus word's frames: the word of the \w-au\ viseme's target if recorded
    word = next(
        (table.representative(v).word for v in ("w-au", "aa", "p") if v in table.visemes), None
    )
    rows = targets[targets["word"] == word] if word else targets.iloc[:1]
    t0 = float(rows["time"].min()) - 0.25
    t1 = float(rows["time"].max()) + 0.25
    frames = range(max(0, int(t0 * video.fps)), min(n_frames, int(t1 * video.fps) + 1))
    strip = [video.frame(k) for k in frames]
    write_png(out.strip, grid(strip, [f"{word} f{k}" for k in frames], cols=8, scale=0.5))
