"""Held-out clips dubbed with their own audio: the measures of
:mod:`miketalk_lab.evaluation.dubbing`
per clip, a side-by-side mp4 (real | dubbed) per clip, a strip of the first, and a summary.

The workflow's ``dub_heldout`` rule runs :func:`dub_heldout`; by hand:
``python -m miketalk_lab.evaluation.dub_heldout --model results/model/s1 --corpus
results/corpus/s1 --config config.yaml --face s1 --out results/dub/s1``.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import LipsyncModel, Trajectory, check_lipsync_model

log = logging.getLogger(__name__)

#: What can draw the dubbed mouth (:data:`miketalk_lab.evaluation.renderers.RENDERERS`).
DUB_RENDERERS = ("morph", "learned", "trained", "trained_heard")


#: The held-out renderer of each lip-sync model (:class:`~miketalk.lipsync.settings.LipsyncModel`).
RENDERER_OF = {
    LipsyncModel.PAPER: "morph",
    LipsyncModel.LEARNED: "learned",
    LipsyncModel.TRAINED: "trained",
}


def dub_renderer(lipsync_model: str, model_dir: str | Path) -> str:
    """The renderer a face's lip-sync model dubs with (:data:`RENDERER_OF`); the trained face
    draws the clip's own recording along the trajectory its build chose for a recording
    (``trained_pooled``), else hears it (``trained_heard``) when it has that trajectory, as
    ``miketalk dub --audio`` does (:meth:`~miketalk.draw.trained.TrainedFace.kind_for`).

    Raises
    ------
    MiketalkError
        For an unknown lip-sync model, naming the known ones.
    """
    import json

    from miketalk.model.parts import TRAINED_DIRECTORY, TRAINED_MANIFEST, trained_trajectories

    model = check_lipsync_model(lipsync_model)
    kinds = trained_trajectories(model_dir) if model == LipsyncModel.TRAINED else ()
    if not kinds:
        return RENDERER_OF[model]
    manifest = Path(model_dir) / TRAINED_DIRECTORY / TRAINED_MANIFEST
    chosen = json.loads(manifest.read_text(encoding="utf-8")).get("recording")  # its build's
    kind = next((k for k in (chosen, Trajectory.HEARD) if k in kinds), None)
    return f"{RENDERER_OF[model]}_{kind}" if kind else RENDERER_OF[model]


def dub_heldout(
    *,
    model_dir: str | Path,
    corpus_dir: str | Path,
    clips: list,
    out_dir: str | Path,
    clips_csv: str | Path | None = None,
    summary_csv: str | Path | None = None,
    strip_png: str | Path | None = None,
    draw_strip: Callable[..., np.ndarray] | None = None,
    renderer: str = "learned",
    morph: dict | None = None,
    colour: str = "clip",
    blend: dict | None = None,
    method: str = "feather",
    corpus_eigenlips=None,
    smooth: float = defaults.BACKGROUND_SMOOTH,
    follow: bool = defaults.BLEND_FOLLOW,
    skin: bool = defaults.BLEND_SKIN,
    interpolation: str = defaults.BLEND_INTERPOLATION,
    times: dict | None = None,
) -> pd.DataFrame:
    """Dub every test clip with its own audio; measure, write videos and ``clips.csv``.

    A model built in a face crop is dubbed through the product's own path, at the clips'
    resolution, and measured at full resolution and in the corpus's crop pixels
    (:func:`dub_crop_clips`, :mod:`miketalk_lab.evaluation.dub_crop`); its compositing
    settings are the product's (the others are refused).

    Parameters
    ----------
    model_dir, corpus_dir : path
        The face's model (with its background) and corpus (eigenlips, mouth region).
    clips : list of Clip
        The test clips.
    out_dir : path
        ``<clip>.mp4`` (real | dubbed, the clip's own audio).
    clips_csv, summary_csv : path, optional
        Per-clip measures and their mean and standard deviation over clips
        (default ``clips.csv`` and ``summary.csv`` in ``out_dir``).
    strip_png : path, optional
        Every 5th frame of the first clip, real above dubbed, whole and the
        mouth, drawn by ``draw_strip`` (e.g. :func:`miketalk_lab.figures.dub_strip.strip`:
        figures come after the evaluation, so the caller hands it in).
    draw_strip : callable, optional
        ``draw_strip(frames, split=2, mouth=(x, y, w, h))`` -> the strip image.
    renderer : str
        How the model draws the mouth, one of :data:`DUB_RENDERERS` (:func:`dub_renderer`
        picks a face's); each clip's recording drives ``trained_heard``.
    morph : dict, optional
        The face's morph settings.
    colour : {"clip", "frame"}
        Match the mouth's colour once per clip or frame by frame.
    blend : dict, optional
        Settings of :func:`miketalk.composite.compositor.blend_mask` (its defaults otherwise).
    method : {"feather", "poisson"}
        How the render is blended (:class:`miketalk.composite.compositor.Compositor`).
    corpus_eigenlips : CorpusEigenlips, optional
        The corpus's eigenlips fitted before
        (:func:`miketalk.corpus.eigenlips.read_eigenlips`); None fits them here.
    smooth : float, optional
        Sigma (s) of the transforms' smoothing in time (0: raw).
    follow, skin : bool
        The frame's jaw warped to follow the render's, and the blend kept off the
        reference's backdrop and clothes (:class:`miketalk.composite.compositor.Compositor`).
    interpolation : {"cubic", "linear"}
        Sampling of the render into the frames (:class:`~miketalk.composite.compositor.Compositor`).
    times : dict, optional
        For a face-crop model: filled with each clip's dub time (s, wall), which the tables
        leave out.
    """
    from miketalk.composite.for_model import model_compositor
    from miketalk.corpus.clip_sources import RATE, decode_clip
    from miketalk.corpus.eigenlips import fit_corpus_eigenlips
    from miketalk.lipsync.timeline import plan
    from miketalk.media.video import write_mp4
    from miketalk.model.face import Model
    from miketalk.mouth import mouth_region
    from miketalk.speech.acoustic import Recording
    from miketalk.visemes import SILENCE, default_table
    from miketalk_lab.evaluation.dubbing import dub_clip, dub_measures
    from miketalk_lab.evaluation.heldout import RENDERERS, speech_frames
    from miketalk_lab.evaluation.landmarks import face_landmarks

    if renderer not in DUB_RENDERERS:
        raise MiketalkError(f"cannot dub with {renderer!r} (known: {', '.join(DUB_RENDERERS)})")
    if corpus_eigenlips is None:
        corpus_eigenlips = fit_corpus_eigenlips(corpus_dir)
    eigenlips = corpus_eigenlips.eigenlips
    out = Path(out_dir)
    model = Model(model_dir, morph_options=morph)
    if model.crop is not None:
        model.close()
        _check_product_settings(colour=colour, blend=blend, method=method, smooth=smooth,
                                follow=follow, skin=skin, interpolation=interpolation)  # fmt: skip
        rows = dub_crop_clips(
            model_dir=model_dir, corpus_dir=corpus_dir, clips=clips, out_dir=out,
            renderer=renderer, eigenlips=eigenlips, morph=morph, strip_png=strip_png,
            draw_strip=draw_strip, times=times,
        )  # fmt: skip
        return _write_tables(rows, renderer, clips_csv or out / "clips.csv",
                             summary_csv or out / "summary.csv")  # fmt: skip
    box = mouth_region(corpus_dir)
    stabilizer = model.stabilizer()
    compositor = model_compositor(
        model, model.size, blend=method, follow=follow, skin=skin,
        interpolation=interpolation, **(blend or {}),
    )  # fmt: skip
    landmarks = face_landmarks()
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for clip in clips:
        decoded = decode_clip(clip)
        n = len(decoded.frames)
        timeline = plan(decoded.phones, default_table(), fps=decoded.fps, duration=n / decoded.fps)
        recording = Recording(decoded.samples, RATE)
        renders = np.stack(list(RENDERERS[renderer](model, timeline, recording)))
        started = time.perf_counter()
        dubbed = dub_clip(
            decoded.frames, decoded.fps, renders, stabilizer=stabilizer, compositor=compositor,
            rest=model.image(SILENCE) if colour == "clip" else None, smooth=smooth,
        )  # fmt: skip
        seconds = time.perf_counter() - started
        frame, dub, render = dub_measures(
            dubbed, stabilizer=stabilizer, mouth_box=box, eigenlips=eigenlips,
            speech=speech_frames(timeline), landmarks=landmarks, compositor=compositor,
        )  # fmt: skip
        # the time goes to the log, not the table: the same config gives the same bytes
        log.info("%s: registered and composited %d frames in %.2f s", clip.id, n, seconds)
        row = {"clip": clip.id, "renderer": renderer, "frames": n} | frame
        row |= {f"dub_{k}": v for k, v in dub.items() if k != "frames"}
        row |= {f"render_{k}": v for k, v in render.items() if k != "frames"}
        row["blinks"] = len(dubbed.background.blinks)
        rows.append(row)
        write_mp4(
            out / f"{clip.id}.mp4",
            np.concatenate([dubbed.real, dubbed.dubbed], axis=2),
            fps=decoded.fps,
            audio=decoded.samples,
            rate=RATE,
        )
        if strip_png is not None and draw_strip is not None and len(rows) == 1:
            from miketalk.media.images import write_png

            x, y, w, h = compositor.support
            write_png(
                strip_png,
                draw_strip(np.concatenate([dubbed.real[:40], dubbed.dubbed[:40]], axis=2), split=2,
                      mouth=(x, y, w, h)),
            )  # fmt: skip
        log.info(
            "%s",
            json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}),
        )
    return _write_tables(rows, renderer, clips_csv or out / "clips.csv",
                         summary_csv or out / "summary.csv")  # fmt: skip


def _write_tables(rows: list[dict], renderer: str, clips_csv, summary_csv) -> pd.DataFrame:
    """``clips.csv`` (a row per clip) and ``summary.csv`` (each measure's mean and sd)."""
    from miketalk.media.atomic import write_text_atomic

    table = pd.DataFrame(rows)
    write_text_atomic(clips_csv, table.to_csv(index=False, float_format="%.5f"))
    numbers = table.drop(columns=["clip"]).select_dtypes("number")
    summary = pd.concat([numbers.mean().add_suffix("_mean"), numbers.std(ddof=1).add_suffix("_sd")])
    summary = summary.to_frame().T.assign(clips=len(table), renderer=renderer)
    write_text_atomic(summary_csv, summary.to_csv(index=False, float_format="%.4f"))
    return table


def _check_product_settings(**given) -> None:
    """A crop model is dubbed as ``miketalk dub`` dubs: the compositing's settings are the
    product's (:mod:`miketalk.defaults`), and another is refused in one line."""
    product = {
        "colour": "clip",
        "blend": None,
        "method": "feather",
        "smooth": defaults.BACKGROUND_SMOOTH,
        "follow": defaults.BLEND_FOLLOW,
        "skin": defaults.BLEND_SKIN,
        "interpolation": defaults.BLEND_INTERPOLATION,
    }
    changed = [f"{k}={v!r}" for k, v in given.items() if v != product[k]]
    if changed:
        raise MiketalkError(
            f"a face-crop model is dubbed as `miketalk dub` dubs, with its compositing: "
            f"not {', '.join(changed)}"
        )


def dub_crop_clips(
    *,
    model_dir: str | Path,
    corpus_dir: str | Path,
    clips: list,
    out_dir: str | Path,
    renderer: str,
    eigenlips,
    morph: dict | None = None,
    strip_png: str | Path | None = None,
    draw_strip=None,
    times: dict | None = None,
) -> list[dict]:
    """Dub every test clip of a face-crop model through the product and measure it.

    Parameters
    ----------
    model_dir, corpus_dir : path
        The model (built in a face crop) and its corpus (the crop, reference, mouth box).
    clips : list of Clip
        The test clips.
    out_dir : path
        ``<clip>.mp4``: the clip's frames | the dubbed ones, at the clip's resolution, with
        its sound.
    renderer : str
        How the mouth is drawn (:data:`~miketalk_lab.evaluation.dub_crop.LIPSYNC_OF`).
    eigenlips : Eigenlips
        The corpus's.
    morph : dict, optional
        The face's morph settings.
    strip_png, draw_strip : optional
        The first clip's strip (real above dubbed, whole and the mouth):
        ``draw_strip(frames, split=2, mouth=(x, y, w, h), scale=s)``.
    times : dict, optional
        Filled with each clip's dub time, seconds (wall; kept out of the tables, whose bytes
        the same inputs repeat).

    Returns
    -------
    list of dict
        One row per clip: ``clip``, ``renderer``, ``frames`` (dubbed), ``compared`` (frames
        read back in both), ``untracked`` (frames the product left without a new mouth),
        :func:`~miketalk_lab.evaluation.dub_crop.paste_measures`, ``dub_*`` and ``render_*``
        (:func:`~miketalk_lab.evaluation.dub_crop.read_back`'s frames
        against the real ones) and ``amplitude_kept`` (the dub's lip-opening amplitude over
        the render's).
    """
    from miketalk.corpus.clips import corpus_decoder, corpus_stabilizer
    from miketalk.media.images import write_png
    from miketalk.media.video import write_mp4
    from miketalk.model.face import Model
    from miketalk.mouth import mouth_region
    from miketalk.speech.acoustic import RATE
    from miketalk.visemes import default_table
    from miketalk_lab.evaluation.dub_crop import (
        dub_through_product,
        lipsync_of,
        mouth_span,
        paste_measures,
        read_back,
        side_by_side_frames,
        work_folder,
    )
    from miketalk_lab.evaluation.heldout import MAX_LAG, compare
    from miketalk_lab.evaluation.landmark_scores import ClipLandmarks, landmark_scores
    from miketalk_lab.evaluation.landmarks import face_landmarks

    box = mouth_region(corpus_dir)
    decode, stabilizer = corpus_decoder(corpus_dir), corpus_stabilizer(corpus_dir)
    lipsync = lipsync_of(renderer, model_dir)
    model = Model(model_dir, morph_options=morph)
    landmarks = face_landmarks()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for clip in clips:
        with work_folder() as work:
            dub = dub_through_product(clip, model=model, lipsync=lipsync, work=Path(work))
            log.info("%s: dubbed through the product in %.2f s", clip.id, dub.seconds)
            if times is not None:
                times[clip.id] = dub.seconds
            row = {"clip": clip.id, "renderer": renderer, "frames": len(dub.frames)}
            row["untracked"] = sum(b is None for b in dub.boxes)
            row |= paste_measures(dub)
            real, dubbed, rendered, speech = read_back(
                clip, dub, decode=decode, stabilizer=stabilizer, table=default_table()
            )
        row["compared"] = len(real)
        marks = ClipLandmarks(landmarks, real)
        for name, frames in (("dub", dubbed), ("render", rendered)):
            scores = compare(real, frames, mouth_box=box, eigenlips=eigenlips, speech=speech)
            _, measures = landmark_scores(marks.real, marks.of(frames), speech=speech,
                                          max_lag=MAX_LAG)  # fmt: skip
            row |= {f"{name}_{k}": v for k, v in (scores.summary | measures).items()
                    if k != "frames"}  # fmt: skip
        row["amplitude_kept"] = (
            row["dub_lip_opening_amplitude_speech"] / row["render_lip_opening_amplitude_speech"]
        )
        rows.append(row)
        sound = _clip_sound(clip)
        write_mp4(out / f"{clip.id}.mp4", side_by_side_frames(dub), fps=dub.fps,
                  n_frames=len(dub.frames), audio=sound, rate=RATE)  # fmt: skip
        if strip_png is not None and draw_strip is not None and len(rows) == 1:
            first = np.concatenate([dub.source[:40], dub.frames[:40]], axis=2)
            scale = min(1.0, 256 / dub.frames.shape[2])  # whole frames about 256 px wide
            write_png(strip_png, draw_strip(first, split=2, mouth=mouth_span(dub, 40),
                                            scale=scale))  # fmt: skip
    return rows


def _clip_sound(clip) -> np.ndarray:
    """The clip's sound (a clip cut from one video: its part), mono at the aligner's rate."""
    from miketalk.media.decode import read_media_audio
    from miketalk.speech.acoustic import RATE

    if clip.span is None:
        return read_media_audio(clip.media, rate=RATE)
    return read_media_audio(clip.media, rate=RATE, start=clip.start,
                            duration=clip.span[1] / clip.fps)  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    import yaml

    from miketalk.composite.compositor import INTERPOLATIONS
    from miketalk.corpus.clip_sources import clip_sources

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model", required=True)
    parser.add_argument("--corpus", required=True)
    parser.add_argument("--config", default="config.yaml")
    parser.add_argument("--face", default="s1")
    parser.add_argument("--out", required=True)
    parser.add_argument("--renderer", default="learned", choices=DUB_RENDERERS)
    parser.add_argument("--colour", default="clip", choices=("clip", "frame"))
    parser.add_argument(
        "--blend",
        type=float,
        nargs=5,
        metavar=("HALF_WIDTH", "ABOVE", "BELOW", "CHIN_WIDTH", "FEATHER"),
        help="the blend ellipse in mouth widths (default: miketalk.defaults)",
    )
    parser.add_argument("--method", default="feather", choices=("feather", "poisson"))
    parser.add_argument(
        "--smooth",
        type=float,
        default=defaults.BACKGROUND_SMOOTH,
        help="transforms' smoothing sigma, s (0: raw; default %(default)s)",
    )
    parser.add_argument("--no-follow", action="store_true", help="do not warp the jaw")
    parser.add_argument("--no-skin", action="store_true", help="blend over backdrop and clothes")
    parser.add_argument(
        "--interpolation", default=defaults.BLEND_INTERPOLATION, choices=tuple(INTERPOLATIONS),
        help="how the render is sampled into the frames (default %(default)s)",
    )  # fmt: skip
    parser.add_argument("--clips", nargs="*", help="test clip ids (default: the face's test)")
    parser.add_argument("--times", help="a TSV of each clip's dub time (a face-crop model's)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    face = yaml.safe_load(Path(args.config).read_text())["faces"][args.face]
    corpus = face["corpus"]
    if corpus.get("source") != "clips":
        raise MiketalkError(f"face {args.face} is not built from clips")
    clips = clip_sources(
        args.clips or corpus["test"], media=corpus["media"], transcripts=corpus["transcripts"],
        timings=corpus.get("timings"),
    )  # fmt: skip
    names = ("half_width", "above", "below", "chin_width", "feather")
    times: dict[str, float] = {}
    dub_heldout(
        model_dir=args.model, corpus_dir=args.corpus, clips=clips, out_dir=args.out,
        renderer=args.renderer, morph=face.get("morph"), colour=args.colour,
        blend=dict(zip(names, args.blend, strict=True)) if args.blend else None,
        method=args.method, smooth=args.smooth, follow=not args.no_follow,
        skin=not args.no_skin, interpolation=args.interpolation, times=times,
    )  # fmt: skip
    if args.times:
        Path(args.times).write_text(
            "clip\tseconds\n" + "".join(f"{c}\t{t:.2f}\n" for c, t in times.items()), "utf-8"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
