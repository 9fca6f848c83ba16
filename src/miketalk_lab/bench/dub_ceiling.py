"""A face-crop model's held-out dub beside its ceiling and with the jaw's warp three ways.

``python -m miketalk_lab.bench.dub_ceiling --model M --corpus C --config CFG --face F --out DIR
[--clips ID ...]`` dubs each test clip through the product
(:func:`~miketalk_lab.evaluation.dub_crop.dub_through_product`) and pastes again, each encoded
as the product encodes (:func:`~miketalk.media.video.write_mp4`) and read back in the corpus's
crop pixels (:func:`~miketalk_lab.evaluation.dub_crop_ceiling.read_back_all`):

``real_ref``
    the real frames brought onto the reference through the background's own transforms (the
    render of a perfect model, read as the render is: no paste-back, no encoding);
``roundtrip``
    those pasted back into their own frames by the product's compositor (the ceiling);
``on``, ``face``, ``off``
    the dub's renders pasted with the jaw's warp as before, held inside the crop's keep, or
    none (:data:`~miketalk_lab.evaluation.dub_crop_ceiling.FOLLOWS`);
``render``
    the renders before paste-back.

The pasted ``on``, ``face`` or ``off`` frames must equal the product's to the byte
(``product_way`` names which: the product's default for crop models).

``DIR/ceiling.csv`` holds per clip and way dlib's lip-opening amplitude and r over the speech
and the mouth LMD against the real clip, and for the pasted ways the full-resolution measures
(:func:`~miketalk_lab.evaluation.dub_crop.paste_measures`); the tables printed pair them clip
by clip (:func:`~miketalk_lab.evaluation.paired.paired`): the roundtrip's amplitude over the
real_ref's (the ceiling of ``amplitude_kept``) against the dub's over the render's, and the
warp's ways against ``on``. ``--strip CLIP`` also writes ``DIR/strip_CLIP.png``: the clip's
first 40 frames, every 5th, real, on, face, off, cropped about the mouth.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk_lab.evaluation.paired import paired

log = logging.getLogger(__name__)

#: Landmark measures against the real clip, per way.
MARKS = ("lip_opening_amplitude_speech", "lip_opening_corr_speech", "mouth_lmd")

#: Full-resolution measures of the pasted ways.
PASTE = ("seam_ratio", "moved_outside_px", "psnr_outside")

#: The ways pasted, encoded and read back.
PASTED = ("roundtrip", "on", "face", "off")


def clip_rows(clip, *, model, lipsync, decode, stabilizer, landmarks, work: Path) -> dict:
    """One clip's row (see the module docstring), and its pasted frames (for a strip)."""
    from miketalk.media.video import write_mp4
    from miketalk.speech.acoustic import RATE
    from miketalk.visemes import default_table
    from miketalk_lab.evaluation.dub_crop import dub_through_product, paste_measures
    from miketalk_lab.evaluation.dub_crop_ceiling import (
        crop_compositor,
        pasted,
        read_back_all,
        real_in_reference,
        roundtrip_frames,
    )
    from miketalk_lab.evaluation.dub_heldout import _clip_sound
    from miketalk_lab.evaluation.heldout import MAX_LAG
    from miketalk_lab.evaluation.landmark_scores import ClipLandmarks, landmark_scores

    dub = dub_through_product(clip, model=model, lipsync=lipsync, work=work)
    sound = _clip_sound(clip)
    steady = real_in_reference(dub, model.size)
    frames = {"roundtrip": roundtrip_frames(dub, steady, crop_compositor(
        model.directory, model.size, "on"))}  # fmt: skip
    for way in ("on", "face", "off"):
        frames[way] = pasted(dub, model, crop_compositor(model, model.size, way))
    product = [w for w in ("on", "face", "off") if np.array_equal(frames[w], dub.frames)]
    if not product:
        raise RuntimeError(f"{clip.id}: no way of pasting gave the product's frames")
    row: dict = {"clip": clip.id, "product_way": product[0]}
    videos = {}
    for way, f in frames.items():
        video = work / f"{clip.id}_{way}.mp4"
        write_mp4(video, f, fps=dub.fps, n_frames=len(f), audio=sound, rate=RATE)
        videos[way] = (video, dub.timings)
        measures = paste_measures(replace_frames(dub, f, video))
        row |= {f"{way}_{m}": measures[m] for m in PASTE}
    real, read, lo, speech = read_back_all(clip, videos, decode=decode, stabilizer=stabilizer,
                                           table=default_table())  # fmt: skip
    n = len(real)
    read["real_ref"] = steady[lo : lo + n]
    read["render"] = dub.renders[lo : lo + n]
    marks = ClipLandmarks(landmarks, real)
    for way, crops in read.items():
        _, scores = landmark_scores(marks.real, marks.of(crops), speech=speech, max_lag=MAX_LAG)
        row |= {f"{way}_{m}": scores[m] for m in MARKS}
    row["compared"] = n
    return row, frames, dub


def replace_frames(dub, frames: np.ndarray, video: Path):
    """``dub`` with other pasted frames and their mp4."""
    from dataclasses import replace

    return replace(dub, frames=frames, video=video)


def tables(table: pd.DataFrame) -> str:
    """The paired tables of ``ceiling.csv`` (see the module docstring)."""
    amp = "lip_opening_amplitude_speech"
    table = table.assign(
        ceiling_kept=table[f"roundtrip_{amp}"] / table[f"real_ref_{amp}"],
        **{f"{w}_kept": table[f"{w}_{amp}"] / table[f"render_{amp}"] for w in ("on", "face",
                                                                           "off")},
    )  # fmt: skip
    lines = [f"{len(table)} clips", "", "| a | b | a mean (sd) | b mean (sd) | b - a (sd) | "
             "95 % interval |", "| --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    pairs = [(f"real_ref_{amp}", f"roundtrip_{amp}"), (f"render_{amp}", f"on_{amp}"),
             ("ceiling_kept", "on_kept")]  # fmt: skip
    for way in ("face", "off"):
        pairs += [(f"on_{m}", f"{way}_{m}") for m in (*MARKS, *PASTE)]
        pairs.append(("on_kept", f"{way}_kept"))
    for a, b in pairs:
        p = paired(table[a], table[b])
        lines.append(
            f"| {a} | {b} | {p['a_mean']:.3f} ({p['a_sd']:.3f}) | {p['b_mean']:.3f} "
            f"({p['b_sd']:.3f}) | {p['diff_mean']:+.3f} ({p['diff_sd']:.3f}) | "
            f"[{p['diff_low']:+.3f}, {p['diff_high']:+.3f}] |"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    import tempfile

    import yaml

    from miketalk.corpus.clip_sources import clip_sources
    from miketalk.corpus.clips import corpus_decoder, corpus_stabilizer
    from miketalk.model.face import Model
    from miketalk_lab.evaluation.dub_crop import lipsync_of
    from miketalk_lab.evaluation.landmarks import face_landmarks

    parser = argparse.ArgumentParser(description=__doc__)
    for name in ("--model", "--corpus", "--config", "--face", "--out"):
        parser.add_argument(name, required=True)
    parser.add_argument("--renderer", default="trained_heard")
    parser.add_argument("--clips", nargs="*", help="test clip ids (default: the face's test)")
    parser.add_argument("--strip", help="a clip whose strip to write")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    corpus = yaml.safe_load(Path(args.config).read_text())["faces"][args.face]["corpus"]
    face = yaml.safe_load(Path(args.config).read_text())["faces"][args.face]
    clips = clip_sources(
        args.clips or corpus["test"], media=corpus["media"], transcripts=corpus["transcripts"],
        timings=corpus.get("timings"),
    )  # fmt: skip
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    model = Model(args.model, morph_options=face.get("morph"))
    common = dict(model=model, lipsync=lipsync_of(args.renderer, args.model),
                  decode=corpus_decoder(args.corpus), stabilizer=corpus_stabilizer(args.corpus),
                  landmarks=face_landmarks())  # fmt: skip
    rows = []
    for clip in clips:
        with tempfile.TemporaryDirectory(prefix="miketalk-dub-ceiling-") as work:
            row, frames, dub = clip_rows(clip, work=Path(work), **common)
        rows.append(row)
        log.info("%s: %s", clip.id, {k: round(v, 3) for k, v in row.items() if "ampl" in k})
        pd.DataFrame(rows).to_csv(out / "ceiling.csv", index=False, float_format="%.5f")
        if clip.id == args.strip:
            write_strip(out / f"strip_{clip.id}.png", dub, frames)
    print(tables(pd.DataFrame(rows).set_index("clip")))
    return 0


def write_strip(path: Path, dub, frames: dict) -> None:
    """Real, on, face, off of the first 40 frames, every 5th, about the mouth (2x)."""
    import cv2

    from miketalk.media.images import write_png
    from miketalk_lab.evaluation.dub_crop import mouth_span

    x, y, w, h = mouth_span(dub, 40)
    pad = w // 3
    x0, y0 = max(0, x - pad), max(0, y - pad)
    x1, y1 = x + w + pad, y + h + pad
    rows = []
    for shown in (dub.source, frames["on"], frames["face"], frames["off"]):
        tiles = [shown[k, y0:y1, x0:x1] for k in range(0, min(40, len(shown)), 5)]
        rows.append(np.concatenate(tiles, axis=1))
    grid = np.concatenate(rows, axis=0)
    write_png(path, cv2.resize(grid, None, fx=2, fy=2, interpolation=cv2.INTER_NEAREST))


if __name__ == "__main__":
    sys.exit(main())
