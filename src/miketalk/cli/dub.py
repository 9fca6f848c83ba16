"""``miketalk dub``: a video of the model's person made to say new speech; ``--background``.

``miketalk dub VIDEO (--text T | --audio A [--text T]) -o OUT.mp4``: every frame
of VIDEO is registered to the model's reference
(:func:`miketalk.composite.background_files.video_background`: through its face crops
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
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError

__all__ = ["add_dub_parser", "cmd_dub"]


def cmd_dub(args: argparse.Namespace) -> int:
    """Make a video of the model's person say new speech (see the module docstring)."""
    from miketalk.cli.common import festival_backend, has_text, read_text, seconds_since
    from miketalk.cli.say import check_lipsync_model, cli_inputs, lipsync_settings
    from miketalk.composite.background_files import video_background
    from miketalk.lipsync.settings import check_fps
    from miketalk.media.decode import video_info
    from miketalk.media.timing import check_constant_rate
    from miketalk.model.background import has_background
    from miketalk.model.parts import default_model_dir
    from miketalk.talk.output import check_output
    from miketalk.talk.say import Recorded, open_model, say

    started = time.perf_counter()
    text = read_text(args) if has_text(args) else None
    if args.audio is None and text is None:
        raise MiketalkError("say what the video should say: --text T, or --audio A [--text T]")
    if args.audio is None and args.timings is not None:
        raise MiketalkError("--timings goes with --audio (the word timings of that recording)")
    if args.audio is not None and args.voice_given:
        raise MiketalkError("--voice picks Festival's voice; with --audio the recording speaks")
    max_px = None if args.sampling == "none" else args.max_px_per_frame
    inputs = cli_inputs(args)
    output = check_output(args.output, overwrite=args.force, inputs=inputs)
    check_lipsync_model(args)
    model_dir = Path(args.model) if args.model is not None else default_model_dir()
    if (model_dir / "manifest.json").exists() and not has_background(model_dir):
        raise MiketalkError(
            f"the model {model_dir} was not built from video of a person: dub needs a model "
            "built from clips of the person in the video (e.g. --model results/model/s1)"
        )
    if not Path(args.video).is_file():
        raise MiketalkError(f"video file not found: {args.video}")
    _, _, fps = video_info(args.video)
    try:
        check_fps(fps)
    except MiketalkError as err:
        raise MiketalkError(f"{args.video}: its frame rate: {err}") from None
    settings = lipsync_settings(args, args.sampling, max_px, fps=fps)
    progress = args.progress or sys.stderr.isatty()

    def register(model):  # the video's frames registered to the model's reference
        background = video_background(
            model, args.video, progress=progress, check_person=not args.force
        )
        check_constant_rate(args.video, fps, len(background))  # shown when they were taken
        return background

    if args.audio is not None:
        with open_model(model_dir) as model:
            background = register(model)
            said = say(
                Recorded(args.audio, text=text, timings=args.timings), output, model=model,
                settings=settings, progress=progress, overwrite=args.force,
                background=background, inputs=inputs,
            )  # fmt: skip
        motion, seconds, trajectory = said.motion, said.duration, said.trajectory
        seconds = min(seconds, motion.frames / fps)  # what the mp4 plays of the recording
    else:
        # Festival works while the video registers
        with festival_backend(args).start(text) as speech, open_model(model_dir) as model:
            background = register(model)
            spoken = say(
                speech, output, model=model, settings=settings, progress=progress,
                overwrite=args.force, background=background, inputs=inputs,
            )  # fmt: skip
        motion, seconds, trajectory = spoken.motion, spoken.motion.duration, None
    timeline = output.with_suffix(".json")
    if args.json:
        doc = {
            "video": str(output),
            "timeline": str(timeline),
            "source": str(args.video),
            "fps": fps,
            "size": list(background.size),
            "source_frames": len(background),
            "blinks": list(background.blinks),
            "frames": motion.frames,
            "audio_seconds": seconds,  # as played: whole frames
            "lipsync_model": args.lipsync_model,
        } | ({"trajectory": trajectory} if trajectory else {})
        print(json.dumps(doc, indent=1, allow_nan=False), file=args.out)
    else:
        loops = "looped" if motion.frames > len(background) else "cut to the speech"
        drawn = f", {trajectory} trajectory" if trajectory else ""
        print(
            f"{output}: {motion.frames} frames at {fps:g} fps, {background.size[1]}x"
            f"{background.size[0]}, {seconds:.2f} s of speech over {len(background)} frames of "
            f"{args.video} ({loops}, {args.lipsync_model} lip-sync{drawn}); timeline in "
            f"{timeline}",
            file=args.out,
        )
    import logging

    logging.getLogger("miketalk").info("dub took %.2f s", seconds_since(started))
    return 0


def add_dub_parser(sub) -> None:
    """Add ``dub`` to the CLI's sub-commands."""
    from miketalk.cli.options import (
        LIPSYNC_MODELS,
        SAMPLINGS,
        checked,
        max_px_value,
        text_options,
        trajectory_option,
        verbose_option,
        voice_option,
    )
    from miketalk.lipsync.settings import Sampling

    dub = sub.add_parser(
        "dub",
        help="make a video of the model's person say new speech (mp4 and timeline .json)",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    dub.add_argument("video", help="a frontal video of the model's person, steady light, >= 1 s")
    text_options(dub)
    dub.add_argument("--audio", help="a recording to speak instead of Festival's voice")
    dub.add_argument("--timings", help="with --audio: its word timings (.align or .TextGrid)")
    dub.add_argument("-o", "--output", required=True, help="the .mp4 to write (and its .json)")
    dub.add_argument("--model", help="a model built from clips of the person in the video")
    dub.add_argument(
        "--sampling",
        choices=[s for s in SAMPLINGS if s != Sampling.PAPER],  # a video cannot be lengthened
        default=Sampling.BLUR.value,
    )
    dub.add_argument(
        "--max-px-per-frame",
        type=checked(max_px_value),
        default=defaults.MAX_PX_PER_FRAME,
        help=f"largest step between morphs, pixels (default {defaults.MAX_PX_PER_FRAME:g})",
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
