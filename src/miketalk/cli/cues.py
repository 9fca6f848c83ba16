"""``miketalk cues``: mouth cues (Rhubarb JSON, TextGrid) for a text or a recording
(:func:`miketalk.api.cues`)."""

from __future__ import annotations

import argparse

from miketalk import api
from miketalk.api import CuesSettings


def cmd_cues(args: argparse.Namespace) -> int:
    """Write mouth cues (Rhubarb JSON/TSV) and timed phones and visemes (Praat TextGrid)."""
    from miketalk.cli.say import cli_inputs, speech_of

    settings = CuesSettings(
        extended_shapes=args.extended_shapes, overwrite=args.force,
        voice=args.voice if args.voice_given else None,
    )  # fmt: skip
    speech = speech_of(args)
    timed = api.cues(speech, args.output or (), settings, wav=args.wav, inputs=cli_inputs(args))
    if not args.output:
        args.out.write(timed.render(args.format))
    return 0
