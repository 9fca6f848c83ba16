"""Right, cut-apart and wrong scripts of joined clips: which words fit the sound, and how.

``python -m miketalk_lab.bench.script_fit --grid DIR --obama DIR [--out OUT] [--limit N]
[--halving]``
joins clips' sound (GRID talker s1's, ``--grid``: the benchmark pool's folder of them; the
weekly-address clips, ``--obama``: their folder, as docs/build.md runs it) one after the other,
as a video made of them holds it, and aligns it as :func:`miketalk.corpus.one_video.segment_video`
does (:func:`miketalk.speech.long_align.align_long` with the fit limit, then
:func:`miketalk.corpus.script_fit.trusted`) to scripts of five kinds:

right
    each clip's own line: GRID's transcripts (10 and ``--limit`` clips, 40 by default:
    every fifth of the pool), and five weekly-address clips whose captions a recogniser
    hears (wa02, wa05-wa08);
one wrong line
    the four weekly-address clips the data's README calls matching (wa01, wa05, wa06,
    wa08): wa01's caption is not what it says (pocketsphinx hears "we have plenty of big
    ideas and technical solutions for ...");
cut-apart
    lines longer than their clip: all eight weekly-address clips with their caption lines,
    and GRID lines with one to three words of another sentence at the start or the end of
    three lines in four;
misheard
    GRID's lines with one word in fifteen replaced by an everyday English word;
wrong
    another video's script: GRID clips with the lines of other GRID clips (the same 51
    words and grammar: the hardest case; the other clips drawn from those not joined, and
    the clips two on in name order, which share the command and colour and half the
    words), the weekly-address sound with GRID lines, GRID's sound with the captions.

Each is a plain transcript (one line per clip), some also subtitles (one cue per clip:
GRID's from its first word to its last, a weekly address's the whole clip). Columns:
``no_fit_left_out`` the words :func:`~miketalk.speech.long_align.align_long` leaves out
without its fit limit (the rule before: refused above 10 %, ``old_rule``);
``left_out`` the words left out now, of which ``misfit`` fit the sound badly and
``short`` fit only in stretches shorter than :data:`~miketalk.corpus.script_fit.MIN_STRETCH`;
``kept_share`` and ``explained`` (the share of the voiced audio under the kept words'
phones), the rule's measures; ``at_edges`` the left-out words in runs that hold a line's
first or last word; against alignment clip by clip (each clip's sound alone with its
line), ``clip_forced`` the words the forced aligner places (a line whole or not at all)
and ``clip_long`` the words the long aligner places, and ``missed_vs_clip`` how many of
the latter the whole recording's alignment leaves out; ``align_s`` the seconds of the
alignment; ``decision`` the rule's (:func:`miketalk.corpus.script_fit.judge`). Writes
``OUT/script_fit.tsv``, ``OUT/script_fit.md`` and ``OUT/unaligned.tsv`` (every word
left out, with its line and why), and prints the table. ``--halving``: the long aligner
before anchors (``align_long(..., anchors=False, fill=False)``), for a paired comparison;
``--no-fill``: the long aligner before its last pass (``align_long(..., fill=False)``:
:mod:`miketalk.speech.long_fill`).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.media.atomic import write_text_atomic
from miketalk_lab.bench.command import bench_parser, run_bench

#: Everyday words put in for GRID's (the misheard case).
_MISHEARD = "table window yellow morning coffee people garden number".split()


@dataclass(frozen=True)
class Case:
    """Clips' sound and a script for it: one line per clip (or another count of lines)."""

    name: str
    kind: str
    clips: tuple[Path, ...]
    lines: tuple[str, ...]
    #: Each clip's spoken span inside it (s), for sentence cues; None: the whole clip.
    spoken: tuple[tuple[float, float], ...] | None = None


def main(argv: Sequence[str] | None = None) -> int:
    """Measure every case; see the module docstring."""
    parser = bench_parser(__name__, __doc__, limit_help="GRID clips in the long cases (40)")
    parser.add_argument("--grid", type=Path, required=True, help="GRID s1 clips' folder")
    parser.add_argument("--obama", type=Path, required=True, help="weekly addresses' folder")
    parser.add_argument("--out", type=Path, default=Path("results/bench/script_fit"))
    parser.add_argument(
        "--halving",
        action="store_true",
        help="the long aligner before anchors: a piece it cannot place is halved at once",
    )
    parser.add_argument(
        "--no-fill",
        action="store_true",
        help="the long aligner before its last pass (the words left out aligned again)",
    )
    return run_bench(parser, argv, _run)


def cases(grid: Path, obama: Path, n: int) -> list[Case]:
    """The cases measured (``n`` GRID clips in the long ones, 10 in the short)."""
    g_text = _table(grid / "transcripts.txt")
    o_text = _table(obama / "transcripts.txt")
    ids = sorted(g_text)
    own = ids[::5][:n]  # every fifth clip
    near = ids[2::5][:n]  # the clip two on: the same command and colour, often more
    rest = sorted(set(ids) - set(ids[::5]))
    other = list(np.random.default_rng(0).choice(rest, size=len(own), replace=False))

    def g_clips(pick):
        return tuple(grid / "video" / f"{i}.mpg" for i in pick)

    def g_lines(pick):
        return tuple(g_text[i] for i in pick)

    def o_clips(pick):
        return tuple(obama / "video" / f"{i}.mp4" for i in pick)

    def o_lines(pick):
        return tuple(o_text[i] for i in pick)

    spoken = tuple(_spoken(grid / "align" / f"{i}.align") for i in own)
    every, heard = sorted(o_text), ["wa02", "wa05", "wa06", "wa07", "wa08"]
    readme = ["wa01", "wa05", "wa06", "wa08"]
    out = []
    for k in (10, n):
        pick = own[:k]
        out += [
            Case(f"grid{k} own lines", "right", g_clips(pick), g_lines(pick)),
            Case(
                f"grid{k} lines with extra words",
                "cut-apart",
                g_clips(pick),
                _longer_lines(g_lines(pick), g_lines(other[:k])),
            ),
            Case(f"grid{k} misheard words", "misheard", g_clips(pick), _misheard(g_lines(pick))),
            Case(f"grid{k} other clips' lines", "wrong", g_clips(pick), g_lines(other[:k])),
        ]
    longer = _longer_lines(g_lines(own), g_lines(other))
    out += [
        Case(f"grid{n} near clips' lines", "wrong", g_clips(own), g_lines(near)),
        Case(f"grid{n} own cues", "right", g_clips(own), g_lines(own), spoken),
        Case(f"grid{n} cues with extra words", "cut-apart", g_clips(own), longer, spoken),
        Case(f"grid{n} other clips' cues", "wrong", g_clips(own), g_lines(other), spoken),
        Case("obama5 heard captions", "right", o_clips(heard), o_lines(heard)),
        Case("obama4 README's matching", "one wrong line", o_clips(readme), o_lines(readme)),
        Case("obama8 captions", "cut-apart", o_clips(every), o_lines(every)),
        Case("obama8 caption cues", "cut-apart", o_clips(every), o_lines(every), ()),
        Case("obama8 with GRID lines", "wrong", o_clips(every), g_lines(other[:15])),
        Case("grid10 with obama captions", "wrong", g_clips(own[:10]), o_lines(every)),
    ]
    return out


def measure(case: Case, anchors: bool = True, fill: bool = True) -> tuple[dict, list[dict]]:
    """A case's row of the table and its left-out words (``anchors``, ``fill``: see
    :func:`~miketalk.speech.long_align.align_long`)."""
    from miketalk.corpus.clip_sources import RATE
    from miketalk.corpus.script import Cue, text_words
    from miketalk.corpus.script_fit import edge_runs, judge, measure_fit, trusted, unaligned_runs
    from miketalk.media.decode import read_media_audio
    from miketalk.speech.align.phones import FIT_LIMIT
    from miketalk.speech.long_align import align_long

    sounds = [read_media_audio(c, rate=RATE) for c in case.clips]
    samples = np.concatenate(sounds)
    starts = np.cumsum([0] + [len(s) / RATE for s in sounds])
    words = [text_words(line) for line in case.lines]
    if case.spoken is None:
        cues = [Cue(tuple(w for line in words for w in line))]
    else:  # one cue per clip: its spoken span, or the whole clip (the weekly addresses')
        spans = case.spoken or [(0.0, len(s) / RATE) for s in sounds]
        cues = [
            Cue(tuple(w), float(t + a), float(t + b))
            for w, t, (a, b) in zip(words, starts[:-1], spans, strict=True)
        ]
    started = time.perf_counter()
    raw = align_long(samples, RATE, cues, fit_limit=FIT_LIMIT, anchors=anchors, fill=fill)
    found = trusted(raw)
    seconds = time.perf_counter() - started
    counts = [len(w) for w in words]
    fit = measure_fit(found, counts, samples, RATE)
    refusal = judge(fit, "the joined clips")
    forced, checked, missed = _clip_by_clip(sounds, words, found, anchors, fill)
    misfit = sum("badly" in u.why for u in raw.unaligned)
    before = len(align_long(samples, RATE, cues, anchors=anchors, fill=fill).unaligned)
    row = {
        "case": case.name,
        "kind": case.kind,
        "script": "transcript" if case.spoken is None else "subtitles",
        "seconds": round(len(samples) / RATE, 1),
        "words": fit.words,
        "no_fit_left_out": before,
        "old_rule": "refused" if before > 0.1 * fit.words else "builds",
        "left_out": fit.left_out,
        "misfit": misfit,
        "short": sum("stretch" in u.why for u in found.unaligned),
        "kept_share": round(fit.kept_share, 3),
        "explained": round(fit.explained_share, 3),
        "at_edges": fit.at_edges,
        "clip_forced": forced,
        "clip_long": checked,
        "missed_vs_clip": missed,
        "align_s": round(seconds, 1),
        "decision": "refused" if refusal else "builds",
    }
    line_of = np.repeat(np.arange(len(words)), counts)
    runs = unaligned_runs([u.index for u in found.unaligned])
    edge = {
        i for (a, b), e in zip(runs, edge_runs(runs, counts), strict=True) if e
        for i in range(a, b + 1)
    }  # fmt: skip
    listed = [
        {"case": case.name, "index": u.index, "line": int(line_of[u.index]) + 1, "word": u.word,
         "at_edge": u.index in edge, "why": u.why}
        for u in found.unaligned
    ]  # fmt: skip
    return row, listed


def _clip_by_clip(sounds, words, found, anchors, fill) -> tuple[int | None, int | None, int | None]:
    """Words placed clip by clip (forced aligner: a line is placed whole or not at all; long
    aligner), and how many of the latter the whole recording's alignment leaves out (None
    when the script has not one line per clip)."""
    from miketalk.corpus.clip_sources import RATE
    from miketalk.corpus.script import Cue
    from miketalk.errors import MiketalkError
    from miketalk.speech.align import align
    from miketalk.speech.align.phones import FIT_LIMIT
    from miketalk.speech.long_align import align_long

    if len(sounds) != len(words):
        return None, None, None
    left_out = {u.index for u in found.unaligned}
    forced = checked = missed = first = 0
    for sound, line in zip(sounds, words, strict=True):
        try:
            forced += len(align(sound, RATE, line).words)
        except MiketalkError:
            pass
        alone = align_long(
            sound, RATE, [Cue(tuple(line))], fit_limit=FIT_LIMIT, anchors=anchors, fill=fill
        )
        checked += len(alone.words)
        missed += sum(first + i in left_out for i, _ in alone.words)
        first += len(line)
    return forced, checked, missed


def _run(args: argparse.Namespace) -> str:
    import pandas as pd

    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    rows, listed = [], []
    for case in cases(args.grid, args.obama, args.limit or 40):
        print(f"{case.name}...", file=sys.stderr, flush=True)
        row, left_out = measure(
            case, anchors=not args.halving, fill=not (args.halving or args.no_fill)
        )
        rows.append(row)
        listed += left_out
    table = pd.DataFrame(rows)
    for column in ("clip_forced", "clip_long", "missed_vs_clip"):
        table[column] = table[column].astype("Int64")
    table.to_csv(out / "script_fit.tsv", sep="\t", index=False, lineterminator="\n")
    pd.DataFrame(listed).to_csv(out / "unaligned.tsv", sep="\t", index=False, lineterminator="\n")
    markdown = _markdown(table)
    write_text_atomic(out / "script_fit.md", markdown)
    return markdown


def _markdown(table) -> str:
    """The table as markdown (a missing value as a dash)."""
    import pandas as pd

    head = "| " + " | ".join(table.columns) + " |"
    rule = "| " + " | ".join("---" for _ in table.columns) + " |"
    body = [
        "| " + " | ".join("-" if v is None or v is pd.NA or v != v else str(v) for v in row) + " |"
        for row in table.itertuples(index=False)
    ]
    return "\n".join([head, rule, *body]) + "\n"


def _table(path: Path) -> dict[str, str]:
    """An ``id text`` file."""
    rows = (line.split(" ", 1) for line in path.read_text(encoding="utf-8").splitlines())
    return {r[0]: r[1] for r in rows if len(r) == 2}


def _spoken(align_file: Path) -> tuple[float, float]:
    """A GRID clip's first word's start and last word's end (s)."""
    from miketalk.speech.word_timings import read_word_timings

    timed = read_word_timings(align_file)
    return timed[0].start, timed[-1].end


def _longer_lines(lines: Sequence[str], others: Sequence[str]) -> tuple[str, ...]:
    """Three lines in four with 1 to 3 words of another sentence at the start or the end (as a
    caption line runs on into the sentence before or after the cut)."""
    out = []
    for i, (line, other) in enumerate(zip(lines, others, strict=True)):
        extra, k = other.split(), 1 + i % 3
        if i % 4 == 3:
            out.append(line)
        elif (i // 2) % 2:
            out.append(" ".join([*extra[-k:], line]))
        else:
            out.append(" ".join([line, *extra[:k]]))
    return tuple(out)


def _misheard(lines: Sequence[str]) -> tuple[str, ...]:
    """One word in fifteen (counted over all the lines) replaced by an everyday word."""
    out, n = [], 0
    for line in lines:
        words = line.split()
        for k in range(len(words)):
            if n % 15 == 7:
                words[k] = _MISHEARD[(n // 15) % len(_MISHEARD)]
            n += 1
        out.append(" ".join(words))
    return tuple(out)


if __name__ == "__main__":
    raise SystemExit(main())
