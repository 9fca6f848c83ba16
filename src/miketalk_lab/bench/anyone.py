"""The mouth on people other than s1: leave-clips-out on the weekly addresses, dubbed and judged.

``python -m miketalk_lab.bench.anyone --obama DIR --out OUT [--fold A,B ...] [--renderer R ...]
[--colour offset|gain|lips] [--patch-light border|session]
[--viseme-light built|session]``

For each fold (default :data:`FOLDS`: every address held out once, two at a time, the
issue's ``wa06,wa08`` first), the other addresses of ``DIR`` (``video/waNN.mp4``,
``transcripts.txt``) are joined with their caption lines
(:func:`miketalk_lab.bench.bad_input.join_addresses`) and built with ``miketalk build``
as a user builds (the lag of the sound behind the mouth over its training utterances
measured here, :mod:`miketalk_lab.evaluation.sound_sync`: the product does not measure it);
each held-out address is then dubbed with its own recording and caption line,
``miketalk dub CLIP --audio CLIP --text LINE --model M``, once per lip-sync model
(:data:`RENDERERS`; ``own``: the one the model chooses for a recording), and once with an
unrelated typed sentence (:data:`UNRELATED`, the row ``unrelated``: what a mouth that
moves without following the speech scores).

The judge is independent of the product: dlib's 68 landmarks on the full-resolution frames
of the real clip and of each dub (the face box found on the real frame, an HD one at half size, and
used for the dub's same frame: the head is where the real one is), the inner-lip opening
divided by the eye distance (:func:`opening`), compared frame by frame:

``r``
    Pearson r of the dub's opening against the real one's over the speech (the frames
    between the first and the last whose sound is within 20 dB of the clip's loud frames);
``amplitude``
    the standard deviation of the dub's opening over the speech over the real one's;
``lag``
    the shift (frames, positive: the dub late) that best aligns the two over the clip,
    :func:`~miketalk_lab.evaluation.measures.lag_frames`; ``r_best`` the r at that shift;
``lmd``, ``centre``
    the mouth landmark distance (points 48-67), and the distance between the two mouths'
    centres (where the mouth is put: the crop path's registration), in pixels of the
    canonical crop (eyes 72 px apart): each frame's distance divided by its eye distance,
    times 72;
``lip_dE``, ``lip_da``
    the lips' colour (inside the outer lip line, outside the inner one, each video's own
    landmarks): the CIELAB distance of the dub's mean colour from the real one's, and the
    difference in a* (positive: redder), over the speech (``lip_dE_sd``: the distance's sd
    over those frames, how much the lips' colour changes).

The calibration row ``real_late1`` is the real landmarks one frame late (a perfect mouth
drawn a frame late). Writes ``OUT/clips.csv`` (one row per clip and renderer),
``OUT/frames.csv`` (every frame's openings), ``OUT/table.md`` (per renderer: mean over
clips and each clip), ``OUT/strip_CLIP.png`` (every tenth frame, mouth region: the
source above each dub) and ``OUT/summary.md``. Models and dubs stay under ``OUT/work``
(each made again only when missing). ``run(out_dir)`` (``python -m miketalk_lab.bench
anyone``) runs it on ``.bench/anyone/config.yaml``'s ``obama`` folder. ``--colour``,
``--patch-light`` and ``--viseme-light`` dub with other colour defaults
(:mod:`miketalk_lab.bench.colour_dub`).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.draw.trained.light import PATCH_LIGHTS, VISEME_LIGHTS
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.model.parts import built_choice
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.evaluation.mouth_follow import lip_colours, pooled_shifts, shifts_table
from miketalk_lab.evaluation.sound_sync import measure_sound_lag, speech_span

ROOT = Path(__file__).resolve().parents[3]

#: Every address held out once, two at a time (the issue's pair first).
FOLDS = (("wa06", "wa08"), ("wa01", "wa02"), ("wa03", "wa04"), ("wa05", "wa07"))
#: Each row's ``miketalk dub`` options (the lip-sync model and trajectory).
RENDERERS = {
    "own": (),
    "morph": ("--lipsync-model", "paper"),
    "learned": ("--lipsync-model", "learned"),
    "trained": ("--trajectory", "window"),
    "trained_heard": ("--trajectory", "heard"),
    "pooled": ("--trajectory", "pooled"),
}
#: What the summary's ``builds`` say of each fold's model.
BUILD_FIGURES = ("build_seconds", "sound_lag_frames", "sound_lag_r", "lipsync_choice")
#: The typed sentence of the ``unrelated`` row.
UNRELATED = "Together we can build a stronger economy for everyone."
#: The lag searched, frames either way.
MAX_LAG = 6
#: The canonical crop's eye distance (pixels): the unit of ``lmd``.
CROP_EYES = 72.0
#: Every how many frames a strip shows one.
STRIP_EVERY = 10


def _miketalk(colour: str | None = None) -> list[str]:
    """The ``miketalk`` command (with the mouth's colour matched by ``colour``, a
    :mod:`miketalk_lab.bench.colour_dub` ``HOW``)."""
    if colour:
        return [sys.executable, "-m", "miketalk_lab.bench.colour_dub", colour]
    return [str(Path(sys.executable).parent / "miketalk")]


def _run(command: list[str], log: Path) -> float:
    """Run a ``miketalk`` command; its stderr to ``log``; its wall seconds. A failure is
    the bench's error (with the command's last line)."""
    started = time.monotonic()
    proc = subprocess.run(command, capture_output=True, text=True)
    log.write_text(proc.stderr, "utf-8")
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
        raise MiketalkError(f"{' '.join(command[:2])} failed on {command[2]}: {tail}")
    return time.monotonic() - started


def opening(points: np.ndarray) -> np.ndarray:
    """The inner-lip opening (pairs 61-67, 62-66, 63-65) over the eye distance (the eyes'
    centres, points 36-41 and 42-47), per frame of ``(N, 68, 2)`` landmarks."""
    from miketalk_lab.evaluation.landmarks import lip_opening

    return lip_opening(points) / eye_distance(points)


def eye_distance(points: np.ndarray) -> np.ndarray:
    """The distance between the eyes' centres, per frame."""
    return np.linalg.norm(points[:, 36:42].mean(axis=1) - points[:, 42:48].mean(axis=1), axis=1)


def real_landmarks(video: Path) -> tuple[np.ndarray, list]:
    """The real clip's landmarks and per frame the face box they were marked from (found
    on the frame, at half size when wider than 640; a frame without a face keeps the
    previous frame's box)."""
    import cv2

    from miketalk.media.decode import iter_video_frames
    from miketalk_lab.evaluation.landmarks import face_landmarks

    marker = face_landmarks()
    points, boxes, box = [], [], None
    for frame in iter_video_frames(video, grey=True):
        scale = 2 if frame.shape[1] > 640 else 1  # an HD frame's face found at half size
        small = cv2.resize(frame, None, fx=1 / scale, fy=1 / scale, interpolation=cv2.INTER_AREA)
        found = marker.detect(small)
        if found is not None:
            box = tuple(scale * v for v in found)
        if box is None:
            raise MiketalkError(f"{video.name}: no face in its first frame")
        boxes.append(box)
        points.append(marker.points(frame[None], box)[0])
    return np.stack(points), boxes


def dub_landmarks(video: Path, boxes: list) -> np.ndarray:
    """A dub's landmarks, each frame marked from the real frame's box."""
    from miketalk.media.decode import iter_video_frames
    from miketalk_lab.evaluation.landmarks import face_landmarks

    marker = face_landmarks()
    points = [
        marker.points(f[None], boxes[k])[0]
        for k, f in enumerate(iter_video_frames(video, grey=True, frames=len(boxes)))
    ]
    return np.stack(points)


def scores(real: np.ndarray, dub: np.ndarray, speech: slice) -> dict[str, float]:
    """The row's measures (the module docstring) of landmarks ``(N, 68, 2)`` each."""
    from miketalk_lab.evaluation.measures import correlation, lag_frames

    n = min(len(real), len(dub))
    real, dub = real[:n], dub[:n]
    a, b = opening(dub), opening(real)
    s = np.arange(n)[speech]
    lag = lag_frames(a, b, max_lag=MAX_LAG)
    shifted = np.arange(max(s[0], lag), min(s[-1] + 1, n + min(lag, 0)))
    shifted = shifted[(shifted - lag >= 0) & (shifted - lag < n)]
    lmd = (
        np.linalg.norm(dub[:, 48:68] - real[:, 48:68], axis=2).mean(axis=1)
        / eye_distance(real)
        * CROP_EYES
    )
    centre = (np.linalg.norm(dub[:, 48:68].mean(axis=1) - real[:, 48:68].mean(axis=1), axis=1)
              / eye_distance(real) * CROP_EYES)  # fmt: skip
    return {
        "centre": float(centre[s].mean()),
        "r": correlation(a[s], b[s]),
        "amplitude": float(a[s].std() / b[s].std()),
        "lag": float(lag),
        "r_best": correlation(a[shifted], b[shifted - lag]),
        "lmd": float(lmd[s].mean()),
        "frames": float(n),
        "speech_frames": float(len(s)),
    }


def _fold_model(obama: Path, work: Path, held: Sequence[str], ids: Sequence[str]) -> dict:
    """The fold's model (built when missing) from every address but ``held``, and how late
    the sound of its training utterances runs behind the mouth (frames, and r there:
    :func:`~miketalk_lab.evaluation.sound_sync.measure_sound_lag`)."""
    from miketalk_lab.bench.bad_input import join_addresses

    train = [a for a in ids if a not in held]
    stem = "train_" + "_".join(held)
    join_addresses(obama, work, train, stem)
    model = work / f"model_{'_'.join(held)}"
    seconds = float("nan")
    if not (model / "manifest.json").is_file():
        seconds = _run(
            [
                *_miketalk(),
                "build",
                str(work / f"{stem}.mp4"),
                "--transcript",
                str(work / f"{stem}.txt"),
                "-o",
                str(model),
            ],
            work / f"build_{'_'.join(held)}.log",
        )
    lag = measure_sound_lag(work / f"{stem}.mp4", model / "build" / "segments.json")
    choice = built_choice(model) or {}  # the build's own lip-sync for a recording
    return {
        "model": model,
        "train": train,
        "build_seconds": seconds,
        "sound_lag_frames": round(lag.peak_frames, 2),
        "sound_lag_r": round(lag.peak_r, 2),
        "lipsync_choice": {
            k: choice[k] for k in ("recording", "scores", "trained_fits") if k in choice
        },
    }


def _dubs(
    clip: Path, line: str, model: Path, work: Path, renderers: Sequence[str], colour: str | None
) -> dict:
    """Each renderer's dub of ``clip`` (made when missing) and the unrelated sentence's, the
    mouth's colour matched by ``colour`` (None: the default's)."""
    out = {}
    for name in [*renderers, "unrelated"]:
        video = work / f"{clip.stem}_{name}{'@' + colour if colour else ''}.mp4"
        if not video.is_file():
            text = UNRELATED if name == "unrelated" else line
            audio = [] if name == "unrelated" else ["--audio", str(clip), *RENDERERS[name]]
            command = [*_miketalk(colour), "dub", str(clip), *audio, "--text", text,
                       "--model", str(model), "-o", str(video), "--force"]  # fmt: skip
            _run(command, video.with_suffix(".log"))
        out[name] = video
    return out


def _mouth_tiles(frames, points: np.ndarray, picks: Sequence[int]) -> np.ndarray:
    """The mouth region of frames ``picks`` (centred on the real mouth, 1.5 eye distances
    wide), 144x96 each, side by side."""
    import cv2

    tiles = []
    eyes = eye_distance(points)
    for k in picks:
        cx, cy = points[k, 48:68].mean(axis=0)
        half = 0.75 * eyes[k]
        src = np.float32(
            [
                [cx - half, cy - half / 1.5],
                [cx + half, cy - half / 1.5],
                [cx - half, cy + half / 1.5],
            ]
        )
        dst = np.float32([[0, 0], [144, 0], [0, 96]])
        tiles.append(cv2.warpAffine(frames[k], cv2.getAffineTransform(src, dst), (144, 96)))
    return np.concatenate(tiles, axis=1)


def strip(real: Path, dubs: dict[str, Path], points: np.ndarray, path: Path) -> None:
    """``path``: every :data:`STRIP_EVERY`-th frame's mouth, the source above each dub."""
    import cv2

    from miketalk.media.decode import read_video

    picks = list(range(0, len(points), STRIP_EVERY))
    rows = []
    for name, video in {"source": real, **dubs}.items():
        frames = read_video(video)[0]
        picks_here = [k for k in picks if k < len(frames)]
        row = _mouth_tiles(frames, points, picks_here)
        row = np.pad(row, ((0, 0), (0, 144 * len(picks) - row.shape[1]), (0, 0)))
        label = np.zeros((96, 130, 3), np.uint8)
        cv2.putText(label, name, (4, 52), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1)
        rows.append(np.concatenate([label, row], axis=1))
    cv2.imwrite(str(path), cv2.cvtColor(np.concatenate(rows, axis=0), cv2.COLOR_RGB2BGR))


def measure_clip(clip: Path, dubs: dict[str, Path], out: Path) -> tuple[list, pd.DataFrame]:
    """The rows of one held-out clip (each dub and ``real_late1``) and its frames' openings."""
    from miketalk.media.decode import read_media_audio, video_info
    from miketalk_lab.evaluation.landmarks import delayed

    real, boxes = real_landmarks(clip)
    real_lips = lip_colours(clip, real)
    fps = video_info(clip)[2]
    rate = 16000
    speech = speech_span(read_media_audio(clip, rate=rate), rate, fps, len(real))
    rows = [{"clip": clip.stem, "renderer": "real_late1", **scores(real, delayed(real, 1), speech)}]
    frames = {
        "clip": clip.stem,
        "frame": np.arange(len(real)),
        "real": opening(real),
        "speech": (np.arange(len(real)) >= speech.start) & (np.arange(len(real)) < speech.stop),
    }
    for name, video in dubs.items():
        points = dub_landmarks(video, boxes)
        lips = lip_colours(video, points) - real_lips[: len(points)]
        spoken = lips[speech]
        rows.append({"clip": clip.stem, "renderer": name, **scores(real, points, speech),
                     "lip_dE": float(np.nanmean(np.linalg.norm(spoken, axis=1))),
                     "lip_dL": float(np.nanmean(spoken[:, 0])),
                     "lip_da": float(np.nanmean(spoken[:, 1])),
                     "lip_db": float(np.nanmean(spoken[:, 2])),
                     "lip_dE_sd": float(np.nanstd(np.linalg.norm(spoken, axis=1)))})  # fmt: skip
        frames[name] = np.pad(opening(points), (0, len(real) - len(points)), constant_values=np.nan)
    strip(clip, dubs, real, out / f"strip_{clip.stem}.png")
    return rows, pd.DataFrame(frames)


def table(clips: pd.DataFrame) -> str:
    """Per renderer the mean (sd) over clips of each measure, and each clip's r and lag."""
    order = [*RENDERERS, "unrelated", "real_late1"]
    lines = [
        "| renderer | clips | r (speech) | amplitude | lag | r at best lag | LMD (crop px) "
        "| centre (crop px) | lips' ΔE | lips' Δa* | r per clip | lag per clip |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name in order:
        part = clips[clips["renderer"] == name]
        if part.empty:
            continue
        cell = [
            f"{part[m].mean():.2f} ({part[m].std(ddof=1):.2f})"
            if m in part and part[m].notna().any()
            else ""
            for m in ("r", "amplitude", "lag", "r_best", "lmd", "centre", "lip_dE", "lip_da")
        ]
        per = " ".join(f"{c[2:]}:{v:+.2f}" for c, v in zip(part["clip"], part["r"], strict=True))
        lags = " ".join(f"{c[2:]}:{v:+.0f}" for c, v in zip(part["clip"], part["lag"], strict=True))
        lines.append(f"| {name} | {len(part)} | {' | '.join(cell)} | {per} | {lags} |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (the module docstring)."""
    parser = bench_parser(__name__, __doc__, limit_help="the first N folds only")
    parser.add_argument("--obama", type=Path, required=True, help="the weekly addresses' folder")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--fold", action="append", default=None,
                        help="addresses held out together, comma-separated (repeat)")  # fmt: skip
    parser.add_argument("--renderer", action="append", choices=list(RENDERERS), default=None)
    parser.add_argument("--colour", choices=("offset", "gain", "lips"), default=None,
                        help="the mouth's colour match (default: the product's)")  # fmt: skip
    for option, what, choices in (
        ("--patch-light", "the trained face's patches", PATCH_LIGHTS),
        ("--viseme-light", "the viseme images", VISEME_LIGHTS),
    ):
        parser.add_argument(option, choices=choices, default=None, help=f"how {what} are "
                            "brought to the face's light (default: the product's)")  # fmt: skip
    return run_bench(parser, argv, _work)


def _work(args) -> str:
    from miketalk.corpus.clip_sources import read_transcripts

    captions = read_transcripts(args.obama / "transcripts.txt")
    ids = sorted(captions)
    folds = [tuple(f.split(",")) for f in args.fold] if args.fold else list(FOLDS)
    folds = folds[: args.limit] if args.limit else folds
    renderers = args.renderer or list(RENDERERS)
    parts = [args.colour] if args.colour else []
    parts += [f"patches={args.patch_light}"] if args.patch_light else []
    parts += [f"visemes={args.viseme_light}"] if args.viseme_light else []
    colour = "+".join(parts) or None  # colour_dub's HOW
    work = args.out / "work"
    work.mkdir(parents=True, exist_ok=True)
    rows, frames, builds, refused = [], [], [], []
    for held in folds:
        unknown = [a for a in held if a not in captions]
        if unknown:
            raise MiketalkError(f"no address {', '.join(unknown)} in {args.obama}")
        fold = _fold_model(args.obama, work, held, ids)
        builds.append({"held": ",".join(held), **{k: fold[k] for k in BUILD_FIGURES}})
        for address in held:
            clip = args.obama / "video" / f"{address}.mp4"
            try:
                dubs = _dubs(clip, captions[address], fold["model"], work, renderers, colour)
            except MiketalkError as err:  # a caption the recording does not say: refused
                refused.append(f"{address}: {err}")
                continue
            got, per_frame = measure_clip(clip, dubs, args.out)
            rows += [{**r, "held": ",".join(held)} for r in got]
            frames.append(per_frame)
    if not rows:
        raise MiketalkError("no held-out address was dubbed: " + "; ".join(refused))
    clips = pd.DataFrame(rows)
    clips.to_csv(args.out / "clips.csv", index=False, float_format="%.4f")
    frames = pd.concat(frames)
    frames.to_csv(args.out / "frames.csv", index=False, float_format="%.4f")
    text = (f"{table(clips)}\nThe opening's r over every held-out clip's speech at once, the "
            f"dub read N frames later (best > 0: it runs late):\n\n"
            f"{shifts_table(pooled_shifts(frames))}")  # fmt: skip
    write_text_atomic(args.out / "table.md", text)
    summary = (
        f"{len(clips['clip'].unique())} held-out addresses, {len(folds)} folds; "
        f"builds {json.dumps(builds)}\n\n{text}"
        + "".join(f"\nNot dubbed, {line}\n" for line in refused)
    )
    write_text_atomic(args.out / "summary.md", summary)
    return summary


def run(out_dir: Path) -> dict[str, float]:
    """Every fold on ``.bench/anyone/config.yaml``'s ``obama`` folder: per renderer the mean r,
    amplitude, lag and LMD over the held-out addresses."""
    import yaml

    config = yaml.safe_load((ROOT / ".bench" / "anyone" / "config.yaml").read_text())
    obama = (ROOT / config["obama"]).resolve()
    if main(["--obama", str(obama), "--out", str(out_dir)]) != 0:
        raise MiketalkError("the anyone bench failed")
    clips = pd.read_csv(out_dir / "clips.csv")
    figures = {}
    for name, part in clips.groupby("renderer"):
        for m in ("r", "amplitude", "lag", "lmd"):
            figures[f"{name}_{m}"] = float(part[m].mean())
    return figures


if __name__ == "__main__":
    sys.exit(main())
