"""The ``miketalk`` command line."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

from miketalk import __version__, defaults
from miketalk.errors import MiketalkError

log = logging.getLogger("miketalk")


def _read_text(args: argparse.Namespace) -> str:
    if getattr(args, "text_option", None) is not None:
        if args.text is not None:
            raise MiketalkError("give the text once: as an argument or with --text")
        args.text = args.text_option
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


def cmd_phones(args: argparse.Namespace) -> int:
    """Print the timed phones of a text with their visemes."""
    from miketalk.speech import get_backend
    from miketalk.visemes import default_table

    utterance = get_backend("festival").synthesize(_read_text(args))
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
            "rate": utterance.rate,
            "n_samples": len(utterance.samples),
            "duration": utterance.duration,
            "phones": rows,
        }
        print(json.dumps(doc, indent=1))
        return 0
    print(f"{'start':>9} {'end':>9}  {'phone':<5} {'label':<5} {'visemes':<9} corpus word")
    for r in rows:
        visemes = "+".join(r["visemes"])
        print(
            f"{r['start']:9.4f} {r['end']:9.4f}  {r['phone']:<5} {r['label']:<5} "
            f"{visemes:<9} {r['word']}"
        )
    last_end = round(utterance.phones[-1].end * utterance.rate)
    print(
        f"# {len(utterance.samples)} samples at {utterance.rate} Hz "
        f"({utterance.duration:.4f} s); last phone ends at sample {last_end} "
        f"(wav - last end = {len(utterance.samples) - last_end} samples)"
    )
    return 0


def cmd_say(args: argparse.Namespace) -> int:
    """Speak a text as an mp4 (Festival's voice), or make the face speak a recording."""
    if args.audio is not None:
        return _say_recorded(args)
    if args.timings is not None:
        raise MiketalkError("--timings goes with --audio (the word timings of that recording)")
    from miketalk.speech import get_backend

    text = _read_text(args)
    # Festival starts first and analyses the text while the rest loads
    with get_backend("festival").start(text) as speech:
        from miketalk.talk.say import open_model, say

        model = open_model(args.model)
        long_text = len(text.split()) > 40
        utterance, timeline = say(
            speech,
            args.output,
            model=model,
            fps=args.fps,
            max_px_per_frame=None if args.no_oversampling else args.max_px_per_frame,
            progress=args.progress or (long_text and sys.stderr.isatty()),
        )
    print(
        f"{args.output}: {len(timeline.frames)} frames at {args.fps:g} fps, "
        f"{utterance.duration:.2f} s of audio"
    )
    return 0


def _say_recorded(args: argparse.Namespace) -> int:
    """``say --audio``: the recording's own sound, its phones found by forced alignment."""
    from miketalk.talk.recorded import say_recorded
    from miketalk.talk.say import open_model

    if args.no_oversampling or args.max_px_per_frame != defaults.MAX_PX_PER_FRAME:
        raise MiketalkError(
            "--audio keeps the recording as it is, so nothing is oversampled: drop "
            "--max-px-per-frame / --no-oversampling"
        )
    given = (args.text, args.text_option, args.file)
    text = None if given == (None, None, None) else _read_text(args)
    model = open_model(args.model)
    said = say_recorded(
        args.audio,
        args.output,
        model=model,
        text=text,
        timings=args.timings,
        fps=args.fps,
        progress=args.progress,
    )
    print(
        f"{args.output}: {len(said.timeline.frames)} frames at {args.fps:g} fps, "
        f"{said.audio_seconds:.2f} s of recorded audio, largest step "
        f"{said.largest_step_px:.2f} px per frame (not oversampled)"
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    parser = argparse.ArgumentParser(
        prog="miketalk", description="Text-to-audiovisual speech by morphing visemes."
    )
    parser.add_argument("--version", action="version", version=f"miketalk {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", required=True)

    phones = sub.add_parser("phones", help="print the timed phones of a text, with visemes")
    phones.add_argument("text", nargs="?", help="the text (or use --file)")
    phones.add_argument("-f", "--file", help="read the text from this UTF-8 file")
    phones.add_argument("--json", action="store_true", help="print JSON")
    phones.set_defaults(func=cmd_phones)

    say = sub.add_parser("say", help="speak a text as a talking-face mp4")
    say.add_argument("text", nargs="?", help="the text (or use --file)")
    say.add_argument("-f", "--file", help="read the text from this UTF-8 file")
    say.add_argument("--text", dest="text_option", help="the text (the same as the argument)")
    say.add_argument("-o", "--output", required=True, help="the mp4 to write")
    say.add_argument("--model", help="model directory (default: the one `make run` builds)")
    say.add_argument(
        "--fps", type=float, default=defaults.FPS, help=f"frame rate (default {defaults.FPS:g})"
    )
    say.add_argument(
        "--max-px-per-frame",
        type=float,
        default=defaults.MAX_PX_PER_FRAME,
        help="oversample transitions moving more than this per frame "
        f"(default {defaults.MAX_PX_PER_FRAME:g})",
    )
    say.add_argument("--no-oversampling", action="store_true", help="turn oversampling off")
    say.add_argument("--progress", action="store_true", help="always show a progress bar")
    say.add_argument(
        "--audio",
        help="speak this recording (wav, mp4, ...) instead of Festival's voice; give what it "
        "says as the text (or --file) or as --timings",
    )
    say.add_argument(
        "--timings", help="with --audio: its word timings (GRID .align or Praat .TextGrid)"
    )
    say.set_defaults(func=cmd_say)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; user mistakes print one clear line and exit with status 2."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="miketalk: %(levelname)s: %(message)s",
    )
    try:
        return args.func(args)
    except MiketalkError as err:
        print(f"miketalk: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("miketalk: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (e.g. `| head`): stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
