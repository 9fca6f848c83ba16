"""``miketalk dub``: a video of the model's person made to say new speech; ``--background``.

``miketalk dub VIDEO (--text T | --audio A [--text T]) -o OUT.mp4`` (a recording without its
text: its words recognized): every frame
of VIDEO is registered to the model's reference
(:func:`miketalk.composite.for_model.video_background`: through its face crops
for a model built in one), the mouth is
synthesized for the new speech at the video's own frame rate, and composited
into every frame at the video's own size (:mod:`miketalk.composite.compositor`),
with the new audio. Speech longer than the video plays the video forwards,
backwards, forwards (no jump); shorter speech ends the video with it.

The same promises as ``say``: a mistake is one line and exit status 2, found
before the work where it can be (a model not built from a person, a video
that cannot be read or lasts less than a second (a variable frame rate is read at its
average rate, :mod:`miketalk.media.decode`),
then a video whose frames do not show the model's person); the mp4 and its
timeline JSON replace an older pair together or not at all; the same inputs give
byte-identical files.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from miketalk import api
from miketalk.api import DubSettings, MiketalkError

__all__ = ["add_dub_parser", "cmd_dub"]


def cmd_dub(args: argparse.Namespace) -> int:
    """Make a video of the model's person say new speech (see the module docstring)."""
    from miketalk.cli.common import output_of, result_out, seconds_since
    from miketalk.cli.say import cli_inputs, speech_of

    started = time.perf_counter()
    speech = speech_of(args, text_needed=False)
    if speech is None:
        raise MiketalkError("say what the video should say: --text T, or --audio A [--text T]")
    settings = DubSettings(
        model=args.model, lipsync_model=args.lipsync_model, trajectory=args.trajectory,
        sampling=args.sampling, max_px_per_frame=args.max_px_per_frame,
        voice=args.voice if args.voice_given else None, overwrite=args.force,
        check_person=not args.force,
    )  # fmt: skip
    dubbed = api.dub(
        args.video, speech, output_of(args), settings,
        progress=args.progress or sys.stderr.isatty(), inputs=cli_inputs(args),
    )  # fmt: skip
    motion, seconds, trajectory = dubbed.motion, dubbed.seconds, dubbed.trajectory
    if args.json:
        doc = {
            "video": str(dubbed.video or "-"),
            "timeline": None if dubbed.timeline_json is None else str(dubbed.timeline_json),
            "source": str(args.video),
            "fps": dubbed.fps,
            "size": list(dubbed.size),
            "source_frames": dubbed.source_frames,
            "blinks": list(dubbed.blinks),
            "frames": motion.frames,
            "audio_seconds": seconds,  # as played: whole frames
            "lipsync_model": dubbed.lipsync_model,
        } | ({"trajectory": trajectory} if trajectory else {})
        print(json.dumps(doc, indent=1, allow_nan=False), file=result_out(args))
    else:
        loops = "looped" if dubbed.looped else "cut to the speech"
        drawn = f", {trajectory} trajectory" if trajectory else ""
        where = f"; timeline in {dubbed.timeline_json}" if dubbed.timeline_json else ""
        print(
            f"{dubbed.video or '-'}: {motion.frames} frames at {dubbed.fps:g} fps, "
            f"{dubbed.size[1]}x{dubbed.size[0]}, {seconds:.2f} s of speech over "
            f"{dubbed.source_frames} frames of {args.video} ({loops}, {dubbed.lipsync_model} "
            f"lip-sync{drawn}){where}",
            file=result_out(args),
        )
    import logging

    logging.getLogger("miketalk").info("dub took %.2f s", seconds_since(started))
    return 0


def add_dub_parser(sub) -> None:
    """Add ``dub`` to the CLI's sub-commands."""
    from miketalk.api.vocabulary import LIPSYNC_MODELS, MAX_PX_PER_FRAME, SAMPLINGS
    from miketalk.cli.options import (
        checked,
        max_px_value,
        phones_option,
        text_options,
        trajectory_option,
        verbose_option,
        voice_option,
    )

    dub = sub.add_parser(
        "dub",
        help="make a video of the model's person say new speech (mp4 and timeline .json)",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    dub.add_argument("video", help="a frontal video of the model's person, steady light, >= 1 s")
    text_options(dub)
    dub.add_argument(
        "--audio",
        help="a recording to speak instead of Festival's voice (without --text: its words "
        "are recognized)",
    )
    dub.add_argument("--timings", help="with --audio: its word timings (.align or .TextGrid)")
    phones_option(dub)
    dub.add_argument(
        "-o",
        "--output",
        required=True,
        help="the .mp4 to write (and its .json); - : a fragmented MP4 on stdout, as it is made",
    )
    dub.add_argument(
        "--model",
        help="a model built from clips of the person in the video (default: $MIKETALK_MODEL, "
        "else one built from the video itself, kept by its checksum for the next dub)",
    )
    dub.add_argument(
        "--sampling",
        choices=[s for s in SAMPLINGS if s != "paper"],  # a video cannot be lengthened
        default="blur",
    )
    dub.add_argument(
        "--max-px-per-frame",
        type=checked(max_px_value),
        default=None,
        help=f"largest step between morphs, pixels (default {MAX_PX_PER_FRAME:g}; none with "
        "--sampling none)",
    )
    dub.add_argument(
        "--lipsync-model",
        choices=LIPSYNC_MODELS,
        default=None,
        help="how the mouth moves, as in `miketalk say` (default: the model's own, trained "
        "for --audio and learned for --text)",
    )
    trajectory_option(dub)
    voice_option(dub)
    dub.add_argument(
        "--force",
        action="store_true",
        help="replace an mp4 or .json miketalk did not write; dub a face that is not the "
        "model's person",
    )
    dub.add_argument("--json", action="store_true", help="print the result as JSON")
    dub.add_argument("--progress", action="store_true", help="always show progress bars")
    verbose_option(dub)
    dub.set_defaults(func=cmd_dub)
