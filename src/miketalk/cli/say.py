"""``miketalk say``: a text or a recording to an mp4 of the face speaking it."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk import defaults
from miketalk.cli.common import festival_backend, has_text, log, read_text, seconds_since
from miketalk.errors import MiketalkError

if TYPE_CHECKING:
    from miketalk.lipsync.settings import LipsyncSettings


def _sampling(args: argparse.Namespace) -> tuple[str, float | None]:
    """The sampling mode and ``max_px_per_frame`` of ``say``'s options, checked together."""
    sampling = args.sampling
    if args.no_oversampling:
        if sampling not in (None, "none"):
            raise MiketalkError(f"--no-oversampling is --sampling none, not {sampling}")
        sampling = "none"
    sampling = sampling or "blur"
    if sampling == "none":
        if args.max_px_per_frame is not None:
            raise MiketalkError("--max-px-per-frame has no effect with --sampling none")
        max_px = None
    else:
        max_px = (
            defaults.MAX_PX_PER_FRAME if args.max_px_per_frame is None else args.max_px_per_frame
        )
    if args.max_slowdown is not None and sampling != "paper":
        raise MiketalkError(
            "--max-slowdown caps how much --sampling paper lengthens the speech; "
            f"--sampling {sampling} keeps the speech's own duration"
        )
    return sampling, max_px


def cmd_say(args: argparse.Namespace) -> int:
    """Speak a text as an mp4 (Festival's voice), or make the face speak a recording."""
    from miketalk.talk.output import check_output

    started = time.perf_counter()
    sampling, max_px = _sampling(args)
    if args.audio is not None:
        return _say_recorded(args, sampling, max_px, started)
    if args.timings is not None:
        raise MiketalkError("--timings goes with --audio (the word timings of that recording)")
    from miketalk.speech.festival.voices import get_voice

    voice = get_voice(args.voice)
    if sampling == "paper" and not voice.follows_durations:
        raise MiketalkError(
            f"the {voice.name} voice sets its own phone durations, so --sampling paper cannot "
            "lengthen them: use --sampling blur (the default) or --voice kal or ked"
        )
    text = read_text(args)
    output = check_output(args.output, overwrite=args.force, inputs=cli_inputs(args))
    check_lipsync_model(args)
    # Festival starts first and analyses the text while the rest loads
    with festival_backend(args).start(text) as speech:
        log.info("Festival started (%s voice)", voice.name)
        from miketalk.talk.say import open_model, say

        with open_model(args.model) as model:
            log.info("model %s opened, %.2f s after start", model.directory, seconds_since(started))
            from miketalk.composite.background_files import resolve_background

            background = resolve_background(
                args.background, model, progress=args.progress, check_person=not args.force
            )
            settings = lipsync_settings(
                args, sampling, max_px, fps=output_fps(args, background, model)
            )
            long_text = len(text.split()) > 40
            spoken = say(
                speech,
                output,
                model=model,
                settings=settings,
                progress=args.progress or (long_text and sys.stderr.isatty()),
                overwrite=args.force,
                background=background,
                inputs=cli_inputs(args),
            )
    motion = spoken.motion
    if args.json:
        doc = {
            "video": str(spoken.video),
            "timeline": str(spoken.timeline_json),
            "fps": args.fps,
            "sampling": sampling,
            "max_px_per_frame": max_px,
            "max_slowdown": args.max_slowdown,
            "lipsync_model": args.lipsync_model,
            "voice": voice.name,
            "motion": motion.to_dict(),
        }
        print(json.dumps(doc, indent=1, allow_nan=False), file=args.out)
    else:
        print(
            f"{spoken.video}: {motion.frames} frames at {args.fps:g} fps, "
            f"{motion.duration:.2f} s of audio ({motion.duration_ratio:.2f} x its own duration), "
            f"{drawn_words(motion)} ({sampling}, {args.lipsync_model} lip-sync); "
            f"timeline in {spoken.timeline_json}",
            file=args.out,
        )
    log.info("say took %.2f s", seconds_since(started))
    return 0


def cli_inputs(args: argparse.Namespace) -> list[str]:
    """The files a command's options name to read (never written over,
    :mod:`miketalk.media.ownership`)."""
    names = ("file", "audio", "timings", "video", "background", "transcript", "subtitles")
    return [str(v) for v in (getattr(args, n, None) for n in names) if isinstance(v, str)]


def recorded_words(seconds: float, frames: int, fps: float) -> str:
    """How much of a recording the mp4 plays (whole frames: at most half a frame more or less
    than the recording), and, when that cuts 0.05 s or more (a low frame rate), what was cut."""
    shown = min(seconds, frames / fps)
    if seconds - shown >= 0.05:
        return (
            f"{shown:.2f} s of the recording's {seconds:.2f} s (its last {seconds - shown:.2f} s "
            f"falls after the last whole frame at {fps:g} fps)"
        )
    return f"{shown:.2f} s of recorded audio"


def drawn_words(motion) -> str:
    """What the summary line says was drawn: the morphs and their largest step, or, when each
    frame is one of the person's own images (the trained face), how many."""
    if motion.largest_step_px is None:
        return (
            f"{motion.frames} of the person's own frames (the step limit does not apply: they "
            "are not morphs)"
        )
    return f"{motion.morphs} morphs, largest step {motion.largest_step_px:.2f} px"


def check_lipsync_model(args: argparse.Namespace) -> None:
    """Settle ``args.lipsync_model`` and check it against the model, in one line if it fails
    (:func:`~miketalk.model.parts.choose_lipsync_model`: not given, it is ``trained`` when a
    ``--trajectory`` is asked for, else the model's own)."""
    from miketalk.model.parts import choose_lipsync_model, default_model_dir

    recorded = args.audio is not None
    directory = args.model if args.model is not None else default_model_dir()
    asked = args.lipsync_model
    args.lipsync_model = choose_lipsync_model(
        directory, asked, trajectory=getattr(args, "trajectory", None), recorded=recorded
    ).value
    if asked is None:
        log.info("lip-sync model %s (the model's own for %s)", args.lipsync_model,
                 "a recording" if recorded else "typed text")  # fmt: skip


def output_fps(args: argparse.Namespace, background, model) -> float:
    """``--fps``, or by default the frame rate of the video a face crop's model plays its
    mouth into (its head motion frame for frame; 29.97 stays 29.97), else
    :data:`miketalk.defaults.FPS`. Sets ``args.fps`` to it."""
    if args.fps is None:
        in_crop = background is not None and model.crop is not None
        args.fps = background.fps if in_crop else defaults.FPS
    return args.fps


def lipsync_settings(
    args: argparse.Namespace, sampling: str, max_px: float | None, fps: float | None = None
) -> LipsyncSettings:
    """The one :class:`~miketalk.lipsync.settings.LipsyncSettings` of the command's options
    (``fps``: a video's own frame rate, for ``dub``)."""
    from miketalk.lipsync.settings import LipsyncSettings

    return LipsyncSettings(
        fps=args.fps if fps is None else fps,
        max_px_per_frame=max_px,
        sampling=sampling,
        max_slowdown=getattr(args, "max_slowdown", None),
        model=args.lipsync_model,
        trajectory=args.trajectory,
    )


def _say_recorded(
    args: argparse.Namespace, sampling: str, max_px: float | None, started: float
) -> int:
    """``say --audio``: the recording's own sound, its phones found by forced alignment."""
    from miketalk.talk.output import check_output

    if sampling == "paper" or args.max_slowdown is not None:
        raise MiketalkError(
            "--audio keeps the recording's own timing, so --sampling paper (which lengthens "
            "the speech) cannot apply: use --sampling blur (the default) or none"
        )
    if args.voice_given:
        raise MiketalkError("--voice picks Festival's voice; with --audio the recording speaks")
    text = read_text(args) if has_text(args) else None
    check_output(args.output, overwrite=args.force, inputs=cli_inputs(args))
    check_lipsync_model(args)
    from miketalk.composite.background_files import resolve_background
    from miketalk.talk.say import Recorded, open_model, say

    with open_model(args.model) as model:
        background = resolve_background(
            args.background, model, progress=args.progress, check_person=not args.force
        )
        settings = lipsync_settings(args, sampling, max_px, fps=output_fps(args, background, model))
        said = say(
            Recorded(args.audio, text=text, timings=args.timings),
            args.output,
            model=model,
            settings=settings,
            progress=args.progress,
            overwrite=args.force,
            background=background,
            inputs=cli_inputs(args),
        )
    motion = said.motion
    if args.json:
        doc = {
            "video": str(args.output),
            "timeline": str(Path(args.output).with_suffix(".json")),
            "audio": str(args.audio),
            "fps": args.fps,
            "sampling": sampling,
            "max_px_per_frame": max_px,
            "lipsync_model": args.lipsync_model,
            "trajectory": said.trajectory,
            "motion": motion.to_dict(),
        }
        print(json.dumps(doc, indent=1, allow_nan=False), file=args.out)
    else:
        drawn = f", {said.trajectory} trajectory" if said.trajectory else ""
        print(
            f"{args.output}: {motion.frames} frames at {args.fps:g} fps, "
            f"{recorded_words(said.duration, motion.frames, args.fps)}, {drawn_words(motion)} "
            f"({sampling}, {args.lipsync_model} lip-sync{drawn})",
            file=args.out,
        )
        if said.trajectory == "heard":
            log.info(
                "the mouth heard the recording (the heard trajectory): for a voice other than "
                "the person's own, --trajectory window draws it better"
            )
    log.info("say took %.2f s", seconds_since(started))
    return 0
