"""``miketalk build``: a talking-face model from one video of a person and what it says.

``miketalk build VIDEO [--transcript T | --subtitles S] -o MODEL_DIR`` runs
:func:`miketalk.building.from_video.build_model_from_video`: the workflow's stages for a
face from one video, one after the other, with a progress bar naming the running stage and
each stage's time on stderr. The work is done in a folder beside MODEL_DIR that is removed
at the end; MODEL_DIR appears only when the model is complete (and replaces an older model
only with --force). The model is what ``say``, ``say --audio`` and
``dub`` take with ``--model``; ``MODEL_DIR/build/`` keeps the utterances found
(``segments.json``) and the corpus's tables of what was left out. Without a transcript or
subtitles the video's words are recognized; those heard without confidence are left out and
named, and ``segments.json`` says which recognizer heard them (``words_from``).

Bad input is one line and exit status 2, before the long work where it can be:
no video or no sound, no face or several, no speech, a transcript in another
language or of another video (without one: speech that is not English, or noise), too
little speech for the viseme classes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from miketalk import api
from miketalk.api import BuildSettings
from miketalk.api.vocabulary import CONVERSIONS, FRAMES

__all__ = ["add_build_parser", "cmd_build"]


def cmd_build(args: argparse.Namespace) -> int:
    """Build a model from one video (see the module docstring)."""
    settings = BuildSettings(
        frame=args.frame, crop_size=args.crop_size, crop_conversion=args.crop_conversion,
        heldout_seconds=args.heldout_seconds, workers=args.workers,
        keep_corpus=args.keep_corpus, overwrite=args.force,
    )  # fmt: skip
    started = time.perf_counter()
    peaks: dict[str, float] = {}

    def report(stage: str, seconds: float, peak: float) -> None:
        peaks[stage] = peak
        if not args.quiet:
            print(f"miketalk build: {stage}: {seconds:.1f} s, peak {peak:.0f} MB", file=sys.stderr)

    built = api.build(
        args.video, args.output, settings, transcript=args.transcript, subtitles=args.subtitles,
        progress=not args.quiet, report=report,
    )  # fmt: skip
    total = time.perf_counter() - started
    summary = {
        "model": str(args.output),
        "utterances": built.utterances,
        "held_out": built.held_out,
        "words": built.words,
        "unaligned_words": built.unaligned_words,
        "recording_lipsync": built.recording_lipsync,
        "trained_cv_r2": built.trained_cv_r2,
        "lipsync_scores": built.lipsync_scores,
        "lipsync_reason": built.lipsync_reason,
        "seconds": round(total, 1),
        "stage_seconds": {k: round(v, 1) for k, v in built.stage_seconds.items()},
        "stage_peak_mb": {k: round(v) for k, v in peaks.items()},
    }
    if args.json:
        print(json.dumps(summary), file=args.out)
    else:
        print(
            f"{args.output}: built from {summary['utterances']} utterances "
            f"({summary['unaligned_words']} of {summary['words']} words not aligned) "
            f"in {total:.0f} s; a recording is drawn by {summary['recording_lipsync']}"
            + (f" ({built.lipsync_reason})" if built.lipsync_reason else ""),
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
    what.add_argument(
        "--transcript", help="what the video says: a plain text file (neither: recognized)"
    )
    what.add_argument("--subtitles", help="its subtitles: .srt or .vtt")
    build.add_argument("-o", "--output", required=True, help="the model directory to write")
    build.add_argument(
        "--heldout-seconds",
        type=float,
        default=BuildSettings.heldout_seconds,
        help="leave the video's last seconds out of the model (default: none)",
    )
    build.add_argument(
        "--workers",
        type=int,
        default=None,
        help="processes to use, 1 to the machine's cores (default 2, or 1 on one core)",
    )
    build.add_argument(
        "--frame",
        choices=FRAMES,
        default=BuildSettings.frame,
        help="crop: track the face and work in a face crop of fixed size, the output at the "
        "video's own resolution (default; any video of one person); full: work in the "
        "video's own pixels (a still head before a plain backdrop, as GRID's)",
    )
    build.add_argument(
        "--crop-size",
        type=int,
        default=None,
        metavar="PX",
        help="the face crop's width and height in pixels (default 256)",
    )
    build.add_argument(
        "--crop-conversion",
        choices=CONVERSIONS,
        default=None,
        help="ffmpeg's YUV-to-RGB conversion of the crops' pixels: auto (default: fast "
        "at HD, accurate below), fast, or accurate (rounded exactly, as the whole frames; "
        "slower at HD)",
    )
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
