"""``miketalk build``: a talking-face model from one video of a person and what it says.

``miketalk build VIDEO (--transcript T | --subtitles S) -o MODEL_DIR`` runs the
workflow's stages for a face from one video (:mod:`miketalk.building.stages`), one
after the other, with a progress bar naming the running stage and each stage's
time on stderr. The work is done in a folder beside MODEL_DIR that is removed at
the end; MODEL_DIR appears only when the model is complete (and replaces an
older model only with --force). The model is what ``say``, ``say --audio`` and
``dub`` take with ``--model``; ``MODEL_DIR/build/`` keeps the utterances found
(``segments.json``) and the corpus's tables of what was left out.

Bad input is one line and exit status 2, before the long work where it can be:
no video or no sound, no face or several, no speech, a transcript in another
language or of another video, too little speech for the viseme classes.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.scratch import scratch_dir

__all__ = ["add_build_parser", "build_model_from_video", "cmd_build"]

#: What MODEL_DIR/build/ keeps of the work.
KEPT = {"segments.json": "segments", "skipped.tsv": "corpus", "clips.tsv": "corpus"}


def build_model_from_video(
    video: str | Path,
    model_dir: str | Path,
    *,
    transcript: str | Path | None = None,
    subtitles: str | Path | None = None,
    heldout_seconds: float = defaults.HELDOUT_SECONDS,
    workers: int = 2,
    force: bool = False,
    progress: bool = True,
    report=None,
    flow: dict | None = None,
    mixed_window: int = defaults.BUILD_MIXED_WINDOW,
    keep_corpus: str | Path | None = None,
) -> dict:
    """Build a model from one video (see the module docstring); the seconds each stage took.

    ``report(stage, seconds, peak_mb)`` is called after each stage (``peak_mb``: the
    largest memory the build's process, or a process it started, has held so far).
    ``flow`` (the flow method's ``estimator`` and ``settings``) and ``mixed_window``
    default to the workflow's defaults; ``keep_corpus`` is where the corpus folder is moved at
    the end (for a held-out test of the model; a new folder), instead of removed.

    Raises
    ------
    MiketalkError
        Bad input (one line), or MODEL_DIR holding something else than a model.
    """
    from tqdm import tqdm

    from miketalk.building.stages import (
        corpus_stage,
        eigenlips_stage,
        flows_stage,
        model_stage,
    )
    from miketalk.corpus.one_video import check_video_inputs, segment_video
    from miketalk.corpus.viseme_choice import choose_visemes_stage

    model_dir = Path(model_dir)
    if model_dir.exists():
        if not force or not (model_dir / "manifest.json").is_file():
            what = "a model" if (model_dir / "manifest.json").is_file() else "something else"
            raise MiketalkError(
                f"{model_dir} exists and holds {what}: give another -o"
                + (" or --force to replace it" if what == "a model" else "")
            )
    if keep_corpus is not None and Path(keep_corpus).exists():
        raise MiketalkError(f"{keep_corpus} exists: --keep-corpus needs a new folder")
    checked = check_video_inputs(  # before any work: one line for a bad video or script
        video, transcript=transcript, subtitles=subtitles, heldout_seconds=heldout_seconds
    )
    model_dir.parent.mkdir(parents=True, exist_ok=True)
    # the work folder beside the model (the model is renamed out of it), swept if killed
    with scratch_dir("build", directory=model_dir.parent) as work:
        spec, strategy = flow or defaults.BUILD_FLOW_METHOD, defaults.BUILD_FLOW_STRATEGY
        corpus, visemes, flows = work / "corpus", work / "visemes", work / "flows"
        segments = work / "segments" / "segments.json"
        settings = {"media": str(Path(video).resolve())}
        out = argparse.Namespace(
            targets=visemes / "candidates.tsv",
            visemes=visemes / "visemes.tsv",
            images=visemes / "images",
            sheet=visemes / "contact_sheet.png",
        )

        def flows_of(name: str, mixed: Path | None = None) -> None:
            flows_stage(
                flows / name,
                flows / f"{name}.tsv",
                visemes=out.visemes,
                images=out.images,
                frames=corpus / "frames",
                spec=spec,
                strategy=name,
                window=mixed_window,
                mixed=mixed,
                regions=corpus / "regions.json",
                workers=workers,
            )

        steps = {
            "segment": lambda: segment_video(
                video, segments, transcript=transcript, subtitles=subtitles,
                heldout_seconds=heldout_seconds, checked=checked,
            ),
            "corpus": lambda: corpus_stage(corpus, settings, segments=segments, workers=workers),
            "visemes": lambda: choose_visemes_stage(corpus_dir=corpus, grouping={}, out=out),
            "eigenlips": lambda: eigenlips_stage(corpus, corpus / "eigenlips.npz"),
            "flows (mixed)": lambda: flows_of("mixed"),
            "flows (bridge)": lambda: flows_of(strategy, mixed=flows / "mixed"),
            "model": lambda: model_stage(
                work / "model", visemes=out.visemes, images=out.images, flows=flows / strategy,
                spec=spec, strategy=strategy, grouping={}, phones=corpus / "phones.tsv",
                eigenlips=corpus / "eigenlips.npz", media=settings["media"], segments=segments,
            ),
        }  # fmt: skip
        seconds: dict[str, float] = {}
        out.visemes.parent.mkdir(parents=True)
        segments.parent.mkdir(parents=True)
        bar = tqdm(total=len(steps), unit="stage", disable=not progress, file=sys.stderr)
        with bar:
            for name, step in steps.items():
                bar.set_description(f"build: {name}")
                started = time.perf_counter()
                step()
                seconds[name] = time.perf_counter() - started
                bar.update(1)
                if report is not None:
                    report(name, seconds[name], peak_mb())
        kept = work / "model" / "build"
        kept.mkdir()
        for name, where in KEPT.items():
            shutil.copyfile(work / where / name, kept / name)
        if model_dir.exists():  # --force: the old model is moved aside, removed with the work
            model_dir.rename(work / "replaced")
        (work / "model").rename(model_dir)
        if keep_corpus is not None:
            Path(keep_corpus).parent.mkdir(parents=True, exist_ok=True)
            shutil.move(corpus, keep_corpus)
    return seconds


def peak_mb() -> float:
    """The largest resident memory (MB) this process or a waited-for child has held."""
    import resource

    who = (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    return max(resource.getrusage(w).ru_maxrss for w in who) / 1024


def cmd_build(args: argparse.Namespace) -> int:
    """Build a model from one video (see the module docstring)."""
    if (args.transcript is None) == (args.subtitles is None):
        raise MiketalkError("give the video's --transcript or its --subtitles (one of them)")
    started = time.perf_counter()
    peaks: dict[str, float] = {}

    def report(stage: str, seconds: float, peak: float) -> None:
        peaks[stage] = peak
        if not args.quiet:
            print(f"miketalk build: {stage}: {seconds:.1f} s, peak {peak:.0f} MB", file=sys.stderr)

    seconds = build_model_from_video(
        args.video,
        args.output,
        transcript=args.transcript,
        subtitles=args.subtitles,
        heldout_seconds=args.heldout_seconds,
        workers=args.workers,
        force=args.force,
        progress=not args.quiet,
        report=report,
        keep_corpus=args.keep_corpus,
    )
    total = time.perf_counter() - started
    segments = json.loads((Path(args.output) / "build" / "segments.json").read_text("utf-8"))
    summary = {
        "model": str(args.output),
        "utterances": sum(u["split"] == "train" for u in segments["utterances"]),
        "held_out": sum(u["split"] == "test" for u in segments["utterances"]),
        "words": segments["words"],
        "unaligned_words": len(segments["unaligned"]),
        "seconds": round(total, 1),
        "stage_seconds": {k: round(v, 1) for k, v in seconds.items()},
        "stage_peak_mb": {k: round(v) for k, v in peaks.items()},
    }
    if args.json:
        print(json.dumps(summary), file=args.out)
    else:
        print(
            f"{args.output}: built from {summary['utterances']} utterances "
            f"({summary['unaligned_words']} of {summary['words']} words not aligned) "
            f"in {total:.0f} s",
            file=args.out,
        )
    return 0


def add_build_parser(sub) -> None:
    """The ``build`` subcommand."""
    from miketalk.cli.options import verbose_option

    build = sub.add_parser(
        "build",
        help="build a talking-face model from one video of a person and its transcript",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    build.add_argument("video", help="a video of one person talking, face to the camera")
    what = build.add_mutually_exclusive_group()
    what.add_argument("--transcript", help="what the video says: a plain text file")
    what.add_argument("--subtitles", help="its subtitles: .srt or .vtt")
    build.add_argument("-o", "--output", required=True, help="the model directory to write")
    build.add_argument(
        "--heldout-seconds",
        type=float,
        default=defaults.HELDOUT_SECONDS,
        help="leave the video's last seconds out of the model (default: none)",
    )
    build.add_argument("--workers", type=int, default=2, help="cores to use (default 2)")
    build.add_argument("--force", action="store_true", help="replace an existing model")
    build.add_argument(
        "--keep-corpus",
        metavar="DIR",
        help="keep the corpus folder (stabilized frames, phones) there, for a held-out test",
    )
    build.add_argument("--quiet", action="store_true", help="no progress bar or stage times")
    build.add_argument("--json", action="store_true", help="print the result as JSON")
    verbose_option(build)
    build.set_defaults(func=cmd_build)
