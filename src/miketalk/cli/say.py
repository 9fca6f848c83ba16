"""``miketalk say``: a text or a recording to an mp4 of the face speaking it
(:func:`miketalk.api.say`)."""

from __future__ import annotations

import argparse
import json
import sys
import time

from miketalk import api
from miketalk.api import MiketalkError, Recorded, SayResult, SaySettings
from miketalk.cli.common import has_text, log, output_of, read_text, result_out, seconds_since


def sampling_options(args: argparse.Namespace) -> str:
    """``--sampling``, with ``--no-oversampling`` (the command line's old name of
    ``--sampling none``) folded in."""
    sampling = args.sampling
    if args.no_oversampling:
        if sampling not in (None, "none"):
            raise MiketalkError(f"--no-oversampling is --sampling none, not {sampling}")
        sampling = "none"
    return sampling or "blur"


def say_settings(args: argparse.Namespace) -> SaySettings:
    """The one :class:`~miketalk.api.SaySettings` of ``say``'s options."""
    return SaySettings(
        model=args.model, lipsync_model=args.lipsync_model, trajectory=args.trajectory,
        sampling=sampling_options(args), max_px_per_frame=args.max_px_per_frame,
        voice=args.voice if args.voice_given else None, overwrite=args.force,
        check_person=not args.force, fps=args.fps, max_slowdown=args.max_slowdown,
        background=args.background,
    )  # fmt: skip


def cli_inputs(args: argparse.Namespace) -> list[str]:
    """The files a command's options name to read (never written over,
    :mod:`miketalk.media.ownership`)."""
    names = ("file", "audio", "timings", "video", "background", "transcript", "subtitles")
    return [str(v) for v in (getattr(args, n, None) for n in names) if isinstance(v, str)]


def speech_of(args: argparse.Namespace, *, text_needed: bool = True) -> str | Recorded:
    """What the options say to speak: ``--audio`` (with its text or ``--timings``), else the
    text (needed with ``text_needed``; else None when none is given)."""
    phones = getattr(args, "phones", "aligned")
    if args.audio is None:
        if args.timings is not None:
            raise MiketalkError("--timings goes with --audio (the word timings of that recording)")
        if phones != "aligned":
            raise MiketalkError("--phones goes with --audio (where its phones come from)")
        return read_text(args) if text_needed or has_text(args) else None
    text = read_text(args) if has_text(args) else None
    return Recorded(args.audio, text=text, timings=args.timings, phones=phones)


def cmd_say(args: argparse.Namespace) -> int:
    """Speak a text as an mp4 (Festival's voice), or make the face speak a recording."""
    started = time.perf_counter()
    settings = say_settings(args)
    speech = speech_of(args)
    long_text = isinstance(speech, str) and len(speech.split()) > 40
    progress = args.progress or (long_text and sys.stderr.isatty())
    output = output_of(args)
    said = api.say(speech, output, settings, progress=progress, inputs=cli_inputs(args))
    if args.json:
        print(json.dumps(_doc(said), indent=1, allow_nan=False), file=result_out(args))
    else:
        print(_summary(said), file=result_out(args))
        if said.trajectory == "heard":
            log.info(
                "the mouth heard the recording (the heard trajectory): for a voice other than "
                "the person's own, --trajectory window draws it better"
            )
    log.info("say took %.2f s", seconds_since(started))
    return 0


def _doc(said: SayResult) -> dict:
    """``say --json``'s document."""
    timeline = None if said.timeline_json is None else str(said.timeline_json)
    where = {"video": str(said.video or "-"), "timeline": timeline}
    drawn = {"fps": said.fps, "sampling": said.sampling.value,
             "max_px_per_frame": said.max_px_per_frame}  # fmt: skip
    if said.recorded:
        return (
            where
            | {"audio": said.audio}
            | drawn
            | {
                "lipsync_model": said.lipsync_model,
                "trajectory": said.trajectory,
                "motion": said.motion.to_dict(),
            }
        )
    return (
        where
        | drawn
        | {
            "max_slowdown": said.max_slowdown,
            "lipsync_model": said.lipsync_model,
            "voice": said.voice,
            "motion": said.motion.to_dict(),
        }
    )


def _summary(said: SayResult) -> str:
    """``say``'s one line."""
    motion = said.motion
    if said.recorded:
        drawn = f", {said.trajectory} trajectory" if said.trajectory else ""
        return (
            f"{said.video or '-'}: {motion.frames} frames at {said.fps:g} fps, "
            f"{recorded_words(said.spoken.duration, motion.frames, said.fps)}, "
            f"{drawn_words(motion)} "
            f"({said.sampling}, {said.lipsync_model} lip-sync{drawn})"
        )
    where = f"; timeline in {said.timeline_json}" if said.timeline_json else ""
    return (
        f"{said.video or '-'}: {motion.frames} frames at {said.fps:g} fps, "
        f"{motion.duration:.2f} s of audio ({motion.duration_ratio:.2f} x its own duration), "
        f"{drawn_words(motion)} ({said.sampling}, {said.lipsync_model} lip-sync){where}"
    )


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
