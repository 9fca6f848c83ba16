"""``miketalk phones``: the timed phones Festival plans for a text."""

from __future__ import annotations

import argparse
import json

from miketalk import api
from miketalk.cli.common import read_text


def cmd_phones(args: argparse.Namespace) -> int:
    """Print the timed phones of a text with their visemes."""
    from miketalk.visemes import default_table

    text = read_text(args)
    utterance = api.phones(text, voice=args.voice)
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
