"""``miketalk cues``: mouth cues (Rhubarb JSON, TextGrid) for a text or a recording."""

from __future__ import annotations

import argparse
from pathlib import Path

from miketalk.cli.common import festival_backend, has_text, log, read_text
from miketalk.errors import MiketalkError


def cmd_cues(args: argparse.Namespace) -> int:
    """Write mouth cues (Rhubarb JSON/TSV) and timed phones and visemes (Praat TextGrid)."""
    from miketalk.lipsync.cues import (
        CUE_KINDS,
        check_extended,
        format_of,
        render_cues,
        write_cues,
    )
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
    from miketalk.cli.say import cli_inputs
    from miketalk.media.atomic import check_writable
    from miketalk.media.ownership import Kind, check_replaceable

    inputs = cli_inputs(args)
    kinds = [(p, CUE_KINDS[format_of(p)]) for p in outputs]
    kinds += [(Path(args.wav), Kind.WAV)] if args.wav is not None else []
    for path, kind in kinds:  # before Festival runs
        option = "--wav" if kind == Kind.WAV else "-o"
        check_replaceable(path, kind, inputs=inputs, force=args.force, option=option)
        check_writable(path)
    table = default_table()
    if args.audio is not None:
        from miketalk.talk.recorded import align_recording

        text = read_text(args) if has_text(args) else None
        aligned = align_recording(args.audio, text=text, timings=args.timings)
        phones, duration = aligned.phones, aligned.duration
        sound_file = str(Path(args.audio).resolve())
    else:
        utterance = festival_backend(args).synthesize(read_text(args))
        phones, duration = utterance.phones, utterance.duration
        sound_file = ""
        if args.wav is not None:
            from miketalk.media.audio import write_wav

            write_wav(
                args.wav, utterance.samples, utterance.rate, software=True,
                guard=lambda: check_replaceable(
                    args.wav, Kind.WAV, inputs=inputs, force=args.force, option="--wav"
                ),
            )  # fmt: skip
            sound_file = str(Path(args.wav).resolve())
    if outputs:
        write_cues(
            outputs,
            phones,
            table,
            duration=duration,
            sound_file=sound_file,
            extended=extended,
            guard=lambda: [
                check_replaceable(p, kind, inputs=inputs, force=args.force)
                for p, kind in kinds
                if kind != Kind.WAV
            ],
        )
        for path in outputs:
            log.info("wrote %s", path)
    else:
        text = render_cues(
            args.format,
            phones,
            table,
            duration=duration,
            sound_file=sound_file,
            extended=extended,
        )
        args.out.write(text)
    return 0
