"""``say --audio`` without the text against with it, on held-out s1 clips, paired clip by clip.

``python -m miketalk_lab.bench.recognized_heldout --corpus DIR --model DIR --pool DIR --out OUT
[--limit N]``: each held-out clip of ``.bench/config.yaml`` (never read by the s1 model of
``make run``, which has the same 40 training clips), from the pool, is decoded and stabilized as
the held-out evaluation reads it (:func:`miketalk_lab.evaluation.heldout.prepare_heldout`), and
drawn twice by the trained face hearing the recording (``trained_heard``, what ``say --audio``
draws with that model): along the phones of its transcript aligned without GRID's timings (``say
--audio --text``), and along those of the words the recognizer hears, aligned
(``say --audio`` alone; :func:`miketalk.talk.recorded.place_phones`). Each is compared with the
real frames (:func:`~miketalk_lab.evaluation.heldout.compare`): the mouth opening's correlation
and lag. A clip the language/noise rule refuses is counted as refused. Writes ``clips.csv`` and
``summary.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from miketalk.corpus.clip_sources import RATE, Clip
from miketalk.errors import MiketalkError
from miketalk_lab.bench.command import bench_parser, run_bench

ROOT = Path(__file__).resolve().parents[3]


def measure(corpus: Path, model_dir: Path, pool: Path, out: Path, limit: int | None) -> str:
    """Every held-out clip (``limit`` of them, spread over the list); the summary."""
    from miketalk.corpus.clips import corpus_decoder, corpus_stabilizer
    from miketalk.corpus.eigenlips import fit_corpus_eigenlips
    from miketalk.model.face import Model
    from miketalk.mouth import mouth_region
    from miketalk.speech.acoustic import Recording
    from miketalk.speech.recognize import recognize_words
    from miketalk.talk.recorded import place_phones
    from miketalk.visemes import VisemeTable
    from miketalk_lab.evaluation.heldout import compare, prepare_heldout, speech_frames
    from miketalk_lab.evaluation.renderers import RENDERERS

    config = yaml.safe_load((ROOT / ".bench" / "config.yaml").read_text())
    ids = config["faces"]["s1"]["corpus"]["test"]
    ids = ids[:: -(-len(ids) // limit)] if limit else ids  # spread over the commands
    texts = dict(
        line.split(" ", 1) for line in (pool / "transcripts.txt").read_text().splitlines() if line
    )
    box, eigenlips = mouth_region(corpus), fit_corpus_eigenlips(corpus).eigenlips
    stabilizer, decode = corpus_stabilizer(corpus), corpus_decoder(corpus)
    table, model = VisemeTable(grouping={}), Model(model_dir)
    rows = []
    for clip_id in ids:
        clip = Clip(clip_id, pool / "video" / f"{clip_id}.mpg", texts[clip_id])
        decoded = decode(clip)  # the transcript aligned alone, as say --audio --text does
        row: dict = {"clip": clip_id}
        ways = {"text": decoded}
        try:
            heard = recognize_words(decoded.samples, RATE, clip_id)
            phones, _ = place_phones(clip_id, decoded.samples, list(heard.words), None, True)
            ways["recognized"] = dataclasses.replace(decoded, phones=phones)
            row["recognized_words"] = " ".join(heard.words)
        except MiketalkError as err:
            row["refused"] = str(err).split(": ", 1)[-1][:60]
        for way, clip_decoded in ways.items():
            held = prepare_heldout(clip, stabilizer=stabilizer, table=table,
                                   decode=lambda _c, d=clip_decoded: d)  # fmt: skip
            render = RENDERERS["trained_heard"](
                model, held.timeline, Recording(held.samples, held.rate)
            )
            scores = compare(held.real, np.stack(list(render)), mouth_box=box,
                             eigenlips=eigenlips, speech=speech_frames(held.timeline))  # fmt: skip
            for key in ("opening_corr", "opening_lag", "opening_corr_speech"):
                row[f"{way}_{key}"] = scores.summary[key]
        rows.append(row)
    clips = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    clips.to_csv(out / "clips.csv", index=False)
    text = summary(clips)
    (out / "summary.md").write_text(text, "utf-8")
    return text


def summary(clips: pd.DataFrame) -> str:
    """The paired table of ``summary.md``."""
    both = clips.dropna(subset=["recognized_opening_corr"])
    diff = both.recognized_opening_corr - both.text_opening_corr
    lag = (both.recognized_opening_lag - both.text_opening_lag).abs()
    lines = [
        "# say --audio without its text against with it (held-out s1 clips, trained face, heard)",
        "",
        f"{len(clips)} clips; {len(clips) - len(both)} refused by the language/noise rule.",
        "",
        "| phones from | clips | opening r mean | sd | in speech | lag mean (frames) | "
        "lag within 1 of the real |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for way in ("text", "recognized"):
        lines.append(
            f"| {way} | {len(both)} | {both[f'{way}_opening_corr'].mean():.3f} | "
            f"{both[f'{way}_opening_corr'].std(ddof=1):.3f} | "
            f"{both[f'{way}_opening_corr_speech'].mean():.3f} | "
            f"{both[f'{way}_opening_lag'].mean():+.2f} | "
            f"{(both[f'{way}_opening_lag'].abs() <= 1).mean():.2f} |"
        )
    half = 1.96 * diff.std(ddof=1) / np.sqrt(len(diff)) if len(diff) > 1 else float("nan")
    lines += [
        "",
        f"Paired, recognized minus text: opening r {diff.mean():+.3f} ± {half:.3f} (95 %), "
        f"{(diff.abs() <= 0.05).mean():.2f} of the clips within 0.05; the lag the same within "
        f"±1 frame on {(lag <= 1).mean():.2f} of them.",
    ]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (module docstring)."""
    parser: argparse.ArgumentParser = bench_parser(__name__, __doc__, limit_help="clips")
    parser.add_argument("--corpus", type=Path, default=ROOT / "results" / "corpus" / "s1")
    parser.add_argument("--model", type=Path, default=ROOT / "results" / "model" / "s1")
    parser.add_argument("--pool", type=Path, required=True, help="GRID-style pool (s1)")
    parser.add_argument("--out", type=Path, required=True)
    return run_bench(parser, argv, lambda a: measure(a.corpus, a.model, a.pool, a.out, a.limit))


if __name__ == "__main__":
    raise SystemExit(main())
