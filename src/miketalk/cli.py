"""The ``miketalk`` command line."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from miketalk import __version__
from miketalk.errors import MiketalkError

log = logging.getLogger("miketalk")


def _read_text(args: argparse.Namespace) -> str:
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

    for register in _EXTRA_COMMANDS:
        register(sub)
    return parser


# Sub-commands defined in other modules add themselves here (see miketalk.cli_say).
_EXTRA_COMMANDS: list[Callable[[argparse._SubParsersAction], None]] = []


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; user mistakes print one clear line and exit with status 2."""
    _load_extra_commands()
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


def _load_extra_commands() -> None:
    import importlib

    for name in ("miketalk.cli_say",):
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as err:
            if err.name != name:
                raise


if __name__ == "__main__":
    sys.exit(main())
