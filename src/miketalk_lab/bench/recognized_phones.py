"""The phones of recognized words against GRID's: phone and viseme error rates, by viseme class.

``python -m miketalk_lab.bench.recognized_phones --pool DIR --out OUT [--limit N]``: for each
clip of a GRID-style pool (``video/<id>.mpg``, ``align/<id>.align``, ``transcripts.txt``) three
phone sequences are placed in its recording by miketalk's forced aligner:

- ``reference``: the transcript's words inside GRID's word timings (the held-out evaluation's
  phones);
- ``text``: the transcript's words alone, as ``say --audio --text`` places them;
- ``recognized``: the words the recognizer hears (:mod:`miketalk.speech.recognize`), as
  ``say --audio`` with no text places them (:func:`miketalk.talk.recorded.place_phones`); a
  clip the language/noise rule refuses is counted as refused.

Phone error rate: the edit distance between a sequence's spoken phones (silence left out) and
the reference's, over the reference's; viseme error rate: the same on their visemes (runs of
one viseme counted once). Frame agreement: every 10 ms of the reference's speech, whether the
viseme shown is the reference's, by the reference's viseme class. Writes ``clips.csv``,
``classes.csv`` and ``summary.md``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio
from miketalk.speech.align import SILENCE, align
from miketalk.speech.recognize import recognize_words
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import read_word_timings
from miketalk.talk.recorded import place_phones
from miketalk.visemes import default_table
from miketalk_lab.bench import recognizer
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.bench.recognizer import read_pool, word_errors

RATE = 16000
HOP = 0.01
WAYS = ("text", "recognized")


def _visemes(phones: Sequence[Phone]) -> list[str]:
    table = default_table()
    out: list[str] = []
    for p in phones:
        for v in table.visemes_of(p.name):
            if v != SILENCE and (not out or out[-1] != v):
                out.append(v)
    return out


def _frames(phones: Sequence[Phone], times: np.ndarray) -> np.ndarray:
    """The (first) viseme shown at each of ``times``."""
    table = default_table()
    ends = np.array([p.end for p in phones])
    index = np.minimum(np.searchsorted(ends, times, side="right"), len(phones) - 1)
    names = np.array([table.visemes_of(p.name)[0] for p in phones])
    return names[index]


def clip_rows(clip: str, media: Path, text: str, timings: Path) -> tuple[dict, pd.DataFrame]:
    """One clip's error rates and its frames' agreement."""
    samples = read_media_audio(media, rate=RATE)
    words = text.split()
    reference = align(samples, RATE, words, word_timings=read_word_timings(timings)).phones
    spoken = [p for p in reference if p.name != SILENCE]
    ref_phones, ref_visemes = [p.name for p in spoken], _visemes(reference)
    times = np.arange(spoken[0].start, spoken[-1].end, HOP) + HOP / 2
    shown = _frames(reference, times)
    row: dict = {"clip": clip, "ref_phones": len(ref_phones), "ref_visemes": len(ref_visemes)}
    frames = {"clip": clip, "viseme": shown}
    t0 = time.perf_counter()
    ways = {"text": align(samples, RATE, words).phones}
    row["text_seconds"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    try:
        heard = recognize_words(samples, RATE, media.name)
        ways["recognized"], _ = place_phones(media, samples, list(heard.words), None, True)
        row["recognized_words"] = " ".join(heard.words)
        row["word_errors"] = word_errors(words, heard.words)
        row["refused"] = ""
    except MiketalkError as err:
        row["refused"] = str(err).split(": ", 1)[-1][:60]
    row["recognized_seconds"] = time.perf_counter() - t0
    for way, phones in ways.items():
        names = [p.name for p in phones if p.name != SILENCE]
        row[f"{way}_phone_errors"] = word_errors(ref_phones, names)
        row[f"{way}_viseme_errors"] = word_errors(ref_visemes, _visemes(phones))
        frames[way] = _frames(phones, times) == shown
    return row, pd.DataFrame(frames)


def measure(pool: Path, out: Path, limit: int | None = None) -> str:
    """Every clip of ``pool`` (spread over it with ``limit``); the summary."""
    clips = read_pool(pool, "{id}.mpg")
    clips = clips[:: -(-len(clips) // limit)] if limit else clips
    rows, frames = [], []
    for clip, media, text in clips:
        row, agree = clip_rows(clip, media, text, pool / "align" / f"{clip}.align")
        rows.append(row)
        frames.append(agree)
    table, agree = pd.DataFrame(rows), pd.concat(frames, ignore_index=True)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "clips.csv", index=False)
    classes = agree.groupby("viseme").agg(
        frames=("clip", "size"), **{f"{w}_agree": (w, "mean") for w in WAYS}
    )
    classes.to_csv(out / "classes.csv")
    agree.to_csv(out / "frames.csv.gz", index=False)
    text = summary(table, classes, agree)
    (out / "summary.md").write_text(text, "utf-8")
    return text


def summary(table: pd.DataFrame, classes: pd.DataFrame, agree: pd.DataFrame) -> str:
    """The tables of ``summary.md``."""
    kept = table[table.refused == ""]
    lines = [
        "# Recognized phones against GRID's timings",
        "",
        f"{len(table)} s1 clips; {len(table) - len(kept)} refused by the language/noise rule "
        "(their rows: the text way only). Reference: the transcript's phones inside GRID's word "
        "timings.",
        "",
        "| phones from | clips | word error rate | phone error rate | viseme error rate | "
        "frames agreeing | s per clip |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for way, rows in (("text", table), ("text", kept), ("recognized", kept)):
        wer = (
            f"{rows.word_errors.sum() / (6 * len(rows)):.3f}"
            if way == "recognized" and "word_errors" in rows
            else "0 (given)"
        )
        shown = agree[agree["clip"].isin(rows["clip"])][way].astype(float).mean()
        lines.append(
            f"| {way}{' (all clips)' if rows is table else ''} | {len(rows)} | {wer} | "
            f"{rows[f'{way}_phone_errors'].sum() / rows.ref_phones.sum():.3f} | "
            f"{rows[f'{way}_viseme_errors'].sum() / rows.ref_visemes.sum():.3f} | "
            f"{shown:.3f} | "
            f"{rows[f'{way}_seconds'].mean():.1f} |"
        )
    lines += [
        "",
        "Frames agreeing by the reference's viseme class (every 10 ms of speech; the recognized "
        "way over the clips it was not refused):",
        "",
        "| viseme | frames | text | recognized |",
        "| --- | --- | --- | --- |",
    ]
    lines += [
        f"| {v} | {r.frames} | {r.text_agree:.3f} | {r.recognized_agree:.3f} |"
        for v, r in classes.sort_values("frames", ascending=False).iterrows()
    ]
    return "\n".join(lines) + "\n"


def run(out_dir: Path) -> dict[str, float]:
    """``make bench``'s run: the recognizer (:mod:`miketalk_lab.bench.recognizer`) on the s1
    pool that ``.bench/config.yaml`` names (all 200 clips) and the weekly addresses beside it,
    then the recognized phones of the s1 pool (``out_dir/phones``); the figures."""
    import yaml

    root = Path(__file__).resolve().parents[3]
    corpus = yaml.safe_load((root / ".bench" / "config.yaml").read_text())["faces"]["s1"]
    pool = (root / corpus["corpus"]["transcripts"]).resolve().parent
    addresses = pool.parent / "obama"
    recognizer.measure(pool, addresses, out_dir)
    measure(pool, out_dir / "phones")
    heard = pd.read_csv(out_dir / "heard.csv")
    figures: dict[str, float] = {}
    for (where, name), g in heard.groupby(["pool", "recognizer"]):
        key = f"{where}_{'whisper' if name == recognizer.DEFAULT_RECOGNIZER else name}"
        figures[f"{key}_wer"] = float(g.errors.sum() / g.ref_words.sum())
        figures[f"{key}_seconds_per_minute"] = float(g.seconds.sum() / (g.audio_s.sum() / 60))
    phones = pd.read_csv(out_dir / "phones" / "clips.csv")
    kept = phones[phones.refused.isna() | (phones.refused == "")]
    figures["s1_refused_share"] = float(1 - len(kept) / len(phones))
    for way in ("text", "recognized"):
        figures[f"{way}_phone_error_rate"] = float(
            kept[f"{way}_phone_errors"].sum() / kept.ref_phones.sum()
        )
        figures[f"{way}_viseme_error_rate"] = float(
            kept[f"{way}_viseme_errors"].sum() / kept.ref_visemes.sum()
        )
    return figures


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (module docstring)."""
    parser: argparse.ArgumentParser = bench_parser(__name__, __doc__, limit_help="s1 clips")
    parser.add_argument("--pool", type=Path, required=True, help="GRID-style pool (s1)")
    parser.add_argument("--out", type=Path, required=True)
    return run_bench(parser, argv, lambda a: measure(a.pool, a.out, a.limit))


if __name__ == "__main__":
    raise SystemExit(main())
