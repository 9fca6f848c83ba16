"""``miketalk say``: text in, talking-face mp4 out."""

from __future__ import annotations

import argparse
import sys

from miketalk.cli import _EXTRA_COMMANDS, _read_text


def cmd_say(args: argparse.Namespace) -> int:
    """Speak a text as an mp4."""
    from miketalk.synthesis import open_model, say

    text = _read_text(args)
    model = open_model(args.model)
    long_text = len(text.split()) > 40
    utterance, timeline = say(
        text,
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


def _register(sub: argparse._SubParsersAction) -> None:
    say = sub.add_parser("say", help="speak a text as a talking-face mp4")
    say.add_argument("text", nargs="?", help="the text (or use --file)")
    say.add_argument("-f", "--file", help="read the text from this UTF-8 file")
    say.add_argument("-o", "--output", required=True, help="the mp4 to write")
    say.add_argument("--model", help="model directory (default: the one `make run` builds)")
    say.add_argument("--fps", type=float, default=30.0, help="frame rate (default 30)")
    say.add_argument(
        "--max-px-per-frame",
        type=float,
        default=2.5,
        help="oversample transitions moving more than this per frame (default 2.5)",
    )
    say.add_argument("--no-oversampling", action="store_true", help="turn oversampling off")
    say.add_argument("--progress", action="store_true", help="always show a progress bar")
    say.set_defaults(func=cmd_say)


_EXTRA_COMMANDS.append(_register)
