"""Options several subcommands share, and the checks of their values."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from miketalk.api.vocabulary import (
    TRAJECTORIES,
    VOICES,
    MiketalkError,
    check_fps,
    check_max_px,
    check_max_slowdown,
)


def checked(check: Callable[[object], object]) -> Callable[[str], float]:
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


fps_value, max_px_value, max_slowdown_value = check_fps, check_max_px, check_max_slowdown


def voice_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--voice",
        choices=tuple(VOICES),
        default=None,
        help="Festival's voice: kal (male diphone, default; festvox-kallpc16k), ked (male "
        "diphone; festvox-kdlpc16k), slt (female HTS, the most natural; festvox-us-slt-hts)",
    )


def trajectory_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--trajectory",
        choices=TRAJECTORIES,
        default=None,
        help="the trained face's trajectory model (it implies --lipsync-model trained): "
        "window (the phone context), "
        "regularized (MMM's) or heard (the phones and the recording: --audio only, and "
        "for the person's own voice: another speaker's recording is drawn better along "
        "window) or pooled (a model of the mouth's motion learned from many talkers, "
        "adapted to the face: --audio only). Default with --audio: the trajectory the "
        "face's build chose, else heard when the face has it; else the face's own",
    )


def verbose_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        default=argparse.SUPPRESS,
        help="log progress and timings on stderr",
    )


def text_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("text", nargs="?", help="the text (or use --file)")
    parser.add_argument("-f", "--file", help="read the text from this UTF-8 file")
    parser.add_argument("--text", dest="text_option", help="the text (the same as the argument)")


def phones_option(parser: argparse.ArgumentParser) -> None:
    """``--phones``: where a recording's phones come from (:data:`miketalk.api.PHONES`)."""
    parser.add_argument(
        "--phones",
        choices=("aligned", "recognized"),
        default="aligned",
        help="with --audio: aligned (default: the text given aligned to the recording, or its "
        "recognized words without one) or recognized (its recognized words even with a text, "
        "which is then compared with them: a warning when they disagree)",
    )
