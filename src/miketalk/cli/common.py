"""What the subcommands share: the text to speak, timing."""

from __future__ import annotations

import argparse
import logging
import time

from miketalk.api import MiketalkError, read_text_file

log = logging.getLogger("miketalk")


def read_text(args: argparse.Namespace) -> str:
    if getattr(args, "text_option", None) is not None:
        if args.text is not None:
            raise MiketalkError("give the text once: as an argument or with --text")
        args.text = args.text_option
        args.text_option = None
    if args.file is not None and args.text is not None:
        raise MiketalkError("give the text or --file, not both")
    if args.file is not None:
        return read_text_file(args.file)
    if args.text is None:
        raise MiketalkError("no text: give it as an argument or with --file")
    return args.text


def has_text(args: argparse.Namespace) -> bool:
    return (args.text, getattr(args, "text_option", None), args.file) != (
        None,
        None,
        None,
    )


def output_of(args: argparse.Namespace) -> str | int:
    """``-o``: the mp4 to write, or with ``-o -`` the descriptor of the real stdout (a
    fragmented MP4 is written on it as it is made).

    Raises
    ------
    MiketalkError
        ``-o -`` with stdout a terminal.
    """
    import os

    if args.output != "-":
        return args.output
    fd = args.out.fileno()
    if os.isatty(fd):
        raise MiketalkError(
            "-o - writes the video on stdout: pipe it into a player (| ffplay -) or a file, "
            "not a terminal"
        )
    args.out.flush()
    return fd


def result_out(args: argparse.Namespace):
    """Where the command's result line goes: stdout, or stderr when the video does."""
    import sys

    return sys.stderr if args.output == "-" else args.out


def seconds_since(started: float) -> float:
    return time.perf_counter() - started
