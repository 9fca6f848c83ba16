"""The ``miketalk`` command line: ``say``, ``cues``, ``phones``; ``dub`` in :mod:`miketalk.cli_dub`.

Every user mistake (a bad setting, an output that cannot be written, a text
Festival cannot read, a broken model) is one line on stderr and exit status 2,
found before the work starts where it can be. stdout carries only the result
(:mod:`miketalk.console`); ``-v`` logs progress and timings on stderr.
SIGTERM and SIGHUP stop a run as Ctrl-C does, and leave nothing behind.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from miketalk import __version__, defaults
from miketalk.console import handle_termination, native_output_logged
from miketalk.errors import MiketalkError

if TYPE_CHECKING:
    from miketalk.speech.festival import FestivalBackend

log = logging.getLogger("miketalk")

_SAMPLINGS = ("blur", "paper", "none")
_LIPSYNC_MODELS = ("paper", "learned")
_VOICES = ("kal", "ked", "slt")


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _checked(check: Callable[[object], object]) -> Callable[[str], float]:
    """An argparse type: a float, then ``check`` (its message says the range)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        try:
            check(value)
        except MiketalkError as err:
            raise argparse.ArgumentTypeError(str(err)) from None
        return value

    return parse


def _fps(value: object) -> object:
    from miketalk.talk.settings import check_fps

    return check_fps(value)


def _max_px(value: object) -> object:
    from miketalk.talk.settings import check_max_px

    return check_max_px(value)


def _max_slowdown(value: object) -> object:
    from miketalk.talk.settings import check_max_slowdown

    return check_max_slowdown(value)


def _read_text(args: argparse.Namespace) -> str:
    if getattr(args, "text_option", None) is not None:
        if args.text is not None:
            raise MiketalkError("give the text once: as an argument or with --text")
        args.text = args.text_option
        args.text_option = None
    if args.file is not None and args.text is not None:
        raise MiketalkError("give the text or --file, not both")
    if args.file is not None:
        try:
            return Path(args.file).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            raise MiketalkError(f"cannot read {args.file}: {err}") from err
    if args.text is None:
        raise MiketalkError("no text: give it as an argument or with --file")
    return args.text


def _has_text(args: argparse.Namespace) -> bool:
    return (args.text, getattr(args, "text_option", None), args.file) != (None, None, None)


def _backend(args: argparse.Namespace) -> FestivalBackend:
    from miketalk.speech import get_backend

    return get_backend("festival", voice=args.voice)


# ---------------------------------------------------------------------------
# phones
# ---------------------------------------------------------------------------


def cmd_phones(args: argparse.Namespace) -> int:
    """Print the timed phones of a text with their visemes."""
    from miketalk.visemes import default_table

    text = _read_text(args)
    utterance = _backend(args).synthesize(text)
    table = default_table()
    rows = [
        {
            "phone": p.name,
            "start": round(p.start, 6),
            "end": round(p.end, 6),
            "label": table.label_of(p.name),
            "visemes": list(table.visemes_of(p.name)),
            "word": table.word_of(p.name),
        }
        for p in utterance.phones
    ]
    if args.json:
        doc = {
            "text": utterance.text,
            "voice": args.voice,
            "rate": utterance.rate,
            "n_samples": len(utterance.samples),
            "duration": utterance.duration,
            "phones": rows,
        }
        print(json.dumps(doc, indent=1, allow_nan=False), file=args.out)
        return 0
    print(
        f"{'start':>9} {'end':>9}  {'phone':<5} {'label':<5} {'visemes':<9} corpus word",
        file=args.out,
    )
    for r in rows:
        visemes = "+".join(r["visemes"])
        print(
            f"{r['start']:9.4f} {r['end']:9.4f}  {r['phone']:<5} {r['label']:<5} "
            f"{visemes:<9} {r['word']}",
            file=args.out,
        )
    last_end = round(utterance.phones[-1].end * utterance.rate)
    print(
        f"# {len(utterance.samples)} samples at {utterance.rate} Hz "
        f"({utterance.duration:.4f} s); last phone ends at sample {last_end} "
        f"(wav - last end = {len(utterance.samples) - last_end} samples)",
        file=args.out,
    )
    return 0


# ---------------------------------------------------------------------------
# say
# ---------------------------------------------------------------------------


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
    text = _read_text(args)
    output = check_output(args.output, overwrite=args.force)
    _check_lipsync_model(args)
    # Festival starts first and analyses the text while the rest loads
    with _backend(args).start(text) as speech:
        log.info("Festival started (%s voice)", voice.name)
        from miketalk.talk.say import open_model, speak

        with open_model(args.model) as model:
            log.info("model %s opened, %.2f s after start", model.directory, _since(started))
            from miketalk.talk.background_files import resolve_background

            background = resolve_background(args.background, model, progress=args.progress)
            long_text = len(text.split()) > 40
            spoken = speak(
                speech,
                output,
                model=model,
                fps=args.fps,
                max_px_per_frame=max_px,
                sampling=sampling,
                max_slowdown=args.max_slowdown,
                lipsync_model=args.lipsync_model,
                progress=args.progress or (long_text and sys.stderr.isatty()),
                overwrite=args.force,
                background=background,
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
            f"{motion.morphs} morphs, largest step {motion.largest_step_px:.2f} px "
            f"({sampling}, {args.lipsync_model} lip-sync); timeline in {spoken.timeline_json}",
            file=args.out,
        )
    log.info("say took %.2f s", _since(started))
    return 0


def _check_lipsync_model(args: argparse.Namespace) -> None:
    """``--lipsync-model learned`` needs a model with learned coarticulation: say so now."""
    if args.lipsync_model != "learned":
        return
    from miketalk.talk.coarticulation import read_params
    from miketalk.talk.say import default_model_dir

    read_params(args.model if args.model is not None else default_model_dir())


def _since(started: float) -> float:
    return time.perf_counter() - started


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
    text = _read_text(args) if _has_text(args) else None
    check_output(args.output, overwrite=args.force)
    _check_lipsync_model(args)
    from miketalk.talk.background_files import resolve_background
    from miketalk.talk.recorded import say_recorded
    from miketalk.talk.say import open_model

    with open_model(args.model) as model:
        background = resolve_background(args.background, model, progress=args.progress)
        said = say_recorded(
            args.audio,
            args.output,
            model=model,
            text=text,
            timings=args.timings,
            fps=args.fps,
            max_px_per_frame=max_px,
            sampling=sampling,
            lipsync_model=args.lipsync_model,
            progress=args.progress,
            overwrite=args.force,
            background=background,
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
            "motion": motion.to_dict(),
        }
        print(json.dumps(doc, indent=1, allow_nan=False), file=args.out)
    else:
        print(
            f"{args.output}: {motion.frames} frames at {args.fps:g} fps, "
            f"{said.audio_seconds:.2f} s of recorded audio, {motion.morphs} morphs, largest "
            f"step {said.largest_step_px:.2f} px ({sampling}, {args.lipsync_model} lip-sync)",
            file=args.out,
        )
    log.info("say took %.2f s", _since(started))
    return 0


# ---------------------------------------------------------------------------
# cues
# ---------------------------------------------------------------------------


def cmd_cues(args: argparse.Namespace) -> int:
    """Write mouth cues (Rhubarb JSON/TSV) and timed phones and visemes (Praat TextGrid)."""
    from miketalk.talk.cues import check_extended, format_of, render_cues, write_cues
    from miketalk.visemes import default_table

    extended = check_extended(args.extended_shapes)
    outputs = [Path(p) for p in args.output or []]
    for path in outputs:
        format_of(path)
        if path.is_dir():
            raise MiketalkError(f"{path} is a directory: name a file to write")
    if args.audio is None and args.timings is not None:
        raise MiketalkError("--timings goes with --audio (the word timings of that recording)")
    if args.audio is not None and args.wav is not None:
        raise MiketalkError(
            "--wav saves Festival's speech; with --audio the recording is the sound"
        )
    if args.audio is not None and args.voice_given:
        raise MiketalkError("--voice picks Festival's voice; with --audio the recording speaks")
    if args.wav is not None and Path(args.wav).suffix.lower() != ".wav":
        raise MiketalkError(f"--wav must name a .wav file, not {Path(args.wav).name!r}")
    from miketalk.media.atomic import check_writable

    for path in [*outputs, *([Path(args.wav)] if args.wav is not None else [])]:
        check_writable(path)  # before Festival runs
    table = default_table()
    if args.audio is not None:
        from miketalk.talk.recorded import align_recording

        text = _read_text(args) if _has_text(args) else None
        aligned = align_recording(args.audio, text=text, timings=args.timings)
        phones, duration = aligned.phones, aligned.duration
        sound_file = str(Path(args.audio).resolve())
    else:
        utterance = _backend(args).synthesize(_read_text(args))
        phones, duration = utterance.phones, utterance.duration
        sound_file = ""
        if args.wav is not None:
            from miketalk.media.audio import write_wav

            write_wav(args.wav, utterance.samples, utterance.rate)
            sound_file = str(Path(args.wav).resolve())
    if outputs:
        write_cues(
            outputs, phones, table, duration=duration, sound_file=sound_file, extended=extended
        )
        for path in outputs:
            log.info("wrote %s", path)
    else:
        text = render_cues(
            args.format, phones, table, duration=duration, sound_file=sound_file, extended=extended
        )
        args.out.write(text)
    return 0


# ---------------------------------------------------------------------------
# the parser
# ---------------------------------------------------------------------------


def _voice_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--voice",
        choices=_VOICES,
        default=None,
        help="Festival's voice: kal (male diphone, default; festvox-kallpc16k), ked (male "
        "diphone; festvox-kdlpc16k), slt (female HTS, the most natural; festvox-us-slt-hts)",
    )


def _verbose_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        default=argparse.SUPPRESS,
        help="log progress and timings on stderr",
    )


def _text_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("text", nargs="?", help="the text (or use --file)")
    parser.add_argument("-f", "--file", help="read the text from this UTF-8 file")
    parser.add_argument("--text", dest="text_option", help="the text (the same as the argument)")


_SAY_HELP = """\
Speak a text as a talking-face video. Writes two files: OUTPUT (an .mp4, H.264 video
and AAC audio) and, beside it, OUTPUT with the suffix .json: the timeline of the
frames (phones, keyframes, transitions, each frame's morphs) and the measures of
its motion. The two replace an older pair together or not at all; a .json that
miketalk did not write is not overwritten without --force.

Sampling: a transition that moves more than --max-px-per-frame pixels per frame
is, with --sampling blur (the default), rendered as several morphs averaged into
each frame (motion blur), keeping the speech at its own speed; with --sampling
paper the speech is lengthened so each frame moves at most that far (the
paper's oversampling, optionally capped by --max-slowdown); --sampling none
renders one morph per frame."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    from miketalk.talk.settings import FPS_RANGE, MAX_PX_RANGE

    parser = _Parser(prog="miketalk", description="Text-to-audiovisual speech by morphing visemes.")
    parser.add_argument("--version", action="version", version=f"miketalk {__version__}")
    parser.add_argument(
        "-v", "--verbose", action="store_true", help="log progress and timings on stderr"
    )
    sub = parser.add_subparsers(dest="command", required=True)

    phones = sub.add_parser(
        "phones",
        help="print the timed phones of a text, with visemes",
        description="Print the phones Festival speaks a text with, their times and visemes "
        "(a table, or JSON with --json) on stdout. Writes no file.",
    )
    phones.add_argument("text", nargs="?", help="the text (or use --file)")
    phones.add_argument("-f", "--file", help="read the text from this UTF-8 file")
    phones.add_argument("--json", action="store_true", help="print JSON")
    _voice_option(phones)
    _verbose_option(phones)
    phones.set_defaults(func=cmd_phones)

    say = sub.add_parser(
        "say",
        help="speak a text as a talking-face mp4 (and its timeline .json)",
        description=_SAY_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _text_options(say)
    say.add_argument(
        "-o", "--output", required=True, help="the .mp4 to write (its .json is written beside it)"
    )
    say.add_argument("--model", help="model directory (default: the one `make run` builds)")
    say.add_argument(
        "--fps",
        type=_checked(_fps),
        default=defaults.FPS,
        help=f"frame rate, {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} (default {defaults.FPS:g})",
    )
    say.add_argument(
        "--sampling",
        choices=_SAMPLINGS,
        default=None,
        help="how transitions too fast for --max-px-per-frame are drawn: blur (default: "
        "natural speed, motion blur), paper (lengthen the speech), none",
    )
    say.add_argument(
        "--max-px-per-frame",
        type=_checked(_max_px),
        default=None,
        help="the largest step between consecutive morphs, pixels, "
        f"{MAX_PX_RANGE[0]:g} to {MAX_PX_RANGE[1]:g} (default {defaults.MAX_PX_PER_FRAME:g})",
    )
    say.add_argument(
        "--max-slowdown",
        type=_checked(_max_slowdown),
        default=None,
        help="with --sampling paper: the speech becomes at most this many times longer "
        "(default: as long as the limit needs); what is still too fast is blurred",
    )
    say.add_argument("--no-oversampling", action="store_true", help="the same as --sampling none")
    say.add_argument(
        "--lipsync-model",
        choices=_LIPSYNC_MODELS,
        default=defaults.LIPSYNC_MODEL,
        help="how the mouth moves: paper (each transition from one viseme to the next; "
        f"default {defaults.LIPSYNC_MODEL}) or learned (the coarticulation a model built from "
        "recorded clips has learned)",
    )
    _voice_option(say)
    say.add_argument(
        "--force", action="store_true", help="overwrite a .json that miketalk did not write"
    )
    say.add_argument("--json", action="store_true", help="print the result as JSON")
    say.add_argument("--progress", action="store_true", help="always show a progress bar")
    say.add_argument(
        "--audio",
        help="speak this recording (wav, mp4, ...) instead of Festival's voice; give what it "
        "says as the text (or --file) or as --timings",
    )
    say.add_argument(
        "--timings", help="with --audio: its word timings (GRID .align or Praat .TextGrid)"
    )
    say.add_argument(
        "--background",
        default=None,
        help="what plays under the mouth: auto (default: a model built from clips plays its "
        "person's own frames, head motion and blinks; other models are still), still (the "
        "model's face as it is), or a video of the model's person",
    )
    _verbose_option(say)
    say.set_defaults(func=cmd_say)

    cues = sub.add_parser(
        "cues",
        help="write mouth cues (Rhubarb Lip Sync JSON/TSV) and a Praat TextGrid",
        description="Time a text's mouth shapes for animators and its phones for "
        "phoneticians. Each -o FILE is written in the format its suffix names: .json "
        "(Rhubarb Lip Sync's JSON: mouthCues of shapes A-F, G, H, X), .tsv (Rhubarb's "
        "TSV), .TextGrid (Praat: tiers phones, visemes, keyframes). Without -o, the "
        "--format is printed on stdout. --wav also writes Festival's speech, the sound "
        "the cues belong to. With --audio, a recording's phones are found by forced "
        "alignment instead.",
    )
    _text_options(cues)
    cues.add_argument(
        "-o",
        "--output",
        action="append",
        help="a file to write (.json, .tsv or .TextGrid); may be given several times",
    )
    cues.add_argument(
        "--format",
        choices=("json", "tsv", "textgrid"),
        default="tsv",
        help="what to print on stdout without -o (default tsv, as Rhubarb)",
    )
    cues.add_argument("--wav", help="also write Festival's speech to this .wav")
    cues.add_argument(
        "--extended-shapes",
        default="GHX",
        help="which of Rhubarb's extended shapes G, H, X to use (default GHX; the others "
        "fall back to B, C, A)",
    )
    cues.add_argument("--audio", help="time this recording instead of Festival's speech")
    cues.add_argument("--timings", help="with --audio: its word timings (.align or .TextGrid)")
    _voice_option(cues)
    _verbose_option(cues)
    cues.set_defaults(func=cmd_cues)
    from miketalk.cli_dub import add_dub_parser

    add_dub_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; user mistakes print one clear line and exit with status 2."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if hasattr(args, "voice"):
        args.voice_given = args.voice is not None
        args.voice = args.voice or "kal"
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="miketalk: %(levelname)s: %(message)s",
    )
    if args.verbose:
        logging.getLogger("miketalk").setLevel(logging.INFO)
    with handle_termination(), native_output_logged() as out:
        args.out = out
        try:
            return args.func(args)
        except MiketalkError as err:
            print(f"miketalk: error: {err}", file=sys.stderr)
            return 2
        except KeyboardInterrupt as err:
            signum = getattr(err, "signum", 2)
            print(f"miketalk: {'interrupted' if signum == 2 else 'terminated'}", file=sys.stderr)
            return 128 + signum
        except BrokenPipeError:
            # the reader went away (e.g. `| head`): stop quietly
            import contextlib
            import io
            import os

            with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation):
                os.dup2(os.open(os.devnull, os.O_WRONLY), out.fileno())
            return 0


if __name__ == "__main__":
    sys.exit(main())
