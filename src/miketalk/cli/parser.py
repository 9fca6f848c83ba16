"""The command line's parser: every subcommand and its options."""

from __future__ import annotations

import argparse
from typing import NoReturn

from miketalk import __version__, defaults
from miketalk.api.vocabulary import FPS_RANGE, LIPSYNC_MODELS, MAX_PX_RANGE, SAMPLINGS
from miketalk.cli.build import add_build_parser
from miketalk.cli.cues import cmd_cues
from miketalk.cli.dub import add_dub_parser
from miketalk.cli.options import (
    checked,
    fps_value,
    max_px_value,
    max_slowdown_value,
    phones_option,
    text_options,
    trajectory_option,
    verbose_option,
    voice_option,
)
from miketalk.cli.phones import cmd_phones
from miketalk.cli.say import cmd_say
from miketalk.cli.serve import add_serve_parser


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


_SAY_HELP = """\
Speak a text as a talking-face video. Writes two files: OUTPUT (an .mp4, H.264 video
and AAC audio) and, beside it, OUTPUT with the suffix .json: the timeline of the
frames (phones, keyframes, transitions, each frame's morphs) and the measures of
its motion. The two replace an older pair together or not at all; a file
miketalk did not write (an mp4 without the .json that names it, another .json)
is not replaced without --force, and an input never is.

Sampling: a transition that moves more than --max-px-per-frame pixels per frame
is, with --sampling blur (the default), rendered as several morphs averaged into
each frame (motion blur), keeping the speech at its own speed; with --sampling
paper the speech is lengthened so each frame moves at most that far (the
paper's oversampling, optionally capped by --max-slowdown); --sampling none
renders one morph per frame."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    parser = _Parser(prog="miketalk", description="Text-to-audiovisual speech by morphing visemes.")
    parser.add_argument("--version", action="version", version=f"miketalk {__version__}")
    parser.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="log progress and timings on stderr",
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
    voice_option(phones)
    verbose_option(phones)
    phones.set_defaults(func=cmd_phones)

    say = sub.add_parser(
        "say",
        help="speak a text as a talking-face mp4 (and its timeline .json)",
        description=_SAY_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    text_options(say)
    say.add_argument(
        "-o",
        "--output",
        required=True,
        help="the .mp4 to write (its .json is written beside it); - : a fragmented MP4 on "
        "stdout as it is made (| ffplay -)",
    )
    say.add_argument("--model", help="model directory (default: the one `make run` builds)")
    say.add_argument(
        "--fps",
        type=checked(fps_value),
        default=None,
        help=f"frame rate, {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} (default: a face-crop model's "
        f"video's own, else {defaults.FPS:g})",
    )
    say.add_argument(
        "--sampling",
        choices=SAMPLINGS,
        default=None,
        help="how transitions too fast for --max-px-per-frame are drawn: blur (default: "
        "natural speed, motion blur), paper (lengthen the speech), none",
    )
    say.add_argument(
        "--max-px-per-frame",
        type=checked(max_px_value),
        default=None,
        help="the largest step between consecutive morphs, pixels, "
        f"{MAX_PX_RANGE[0]:g} to {MAX_PX_RANGE[1]:g} (default {defaults.MAX_PX_PER_FRAME:g})",
    )
    say.add_argument(
        "--max-slowdown",
        type=checked(max_slowdown_value),
        default=None,
        help="with --sampling paper: the speech becomes at most this many times longer "
        "(default: as long as the limit needs); what is still too fast is blurred",
    )
    say.add_argument("--no-oversampling", action="store_true", help="the same as --sampling none")
    say.add_argument(
        "--lipsync-model",
        choices=LIPSYNC_MODELS,
        default=None,
        help="how the mouth moves: paper (each transition from one viseme to the next), "
        "learned (the coarticulation a model built from recorded clips has learned) or trained "
        "(his own frames along a trajectory trained on all of them); default: the model's own, "
        "for a model built from clips learned for typed text and trained for --audio "
        "(trained with --trajectory), else paper",
    )
    trajectory_option(say)
    voice_option(say)
    say.add_argument(
        "--force",
        action="store_true",
        help="replace an mp4 or a .json that miketalk did not write (never an input)",
    )
    say.add_argument("--json", action="store_true", help="print the result as JSON")
    say.add_argument("--progress", action="store_true", help="always show a progress bar")
    say.add_argument(
        "--audio",
        help="speak this recording (wav, mp4, ...) instead of Festival's voice; give what it "
        "says as the text (or --file) or as --timings, or neither: its words are recognized",
    )
    say.add_argument(
        "--timings",
        help="with --audio: its word timings (GRID .align or Praat .TextGrid)",
    )
    phones_option(say)
    say.add_argument(
        "--background",
        default=None,
        help="what plays under the mouth: auto (default: a model built from clips plays its "
        "person's own frames, head motion and blinks; other models are still), still (the "
        "model's face as it is), or a video of the model's person",
    )
    verbose_option(say)
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
    text_options(cues)
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
    cues.add_argument(
        "--force",
        action="store_true",
        help="replace an output that miketalk did not write (never an input)",
    )
    cues.add_argument("--timings", help="with --audio: its word timings (.align or .TextGrid)")
    phones_option(cues)
    voice_option(cues)
    verbose_option(cues)
    cues.set_defaults(func=cmd_cues)
    add_dub_parser(sub)
    add_build_parser(sub)
    add_serve_parser(sub)
    return parser
