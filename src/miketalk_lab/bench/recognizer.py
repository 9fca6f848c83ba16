"""Benchmark of the speech recognizer: word error rate, speed, and the language/noise rule.

``python -m miketalk_lab.bench.recognizer --pool DIR --addresses DIR --out OUT [--limit N]``
hears every clip of a GRID-style pool (``video/<id>.mpg``, ``transcripts.txt``; the transcripts
are exact) and of the weekly addresses (``video/waNN.mp4``, ``transcripts.txt``: caption lines,
approximate, some holding words their clip does not), with miketalk's recognizer
(:mod:`miketalk.speech.recognize`, Whisper base) and with pocketsphinx's own US-English
decoder for comparison, and writes

- ``heard.csv``: one row per clip and recognizer: reference, hypothesis, errors, seconds;
- ``rule.csv``: what the language/noise rule (:mod:`miketalk.speech.recognize.judge`) sees on
  English (GRID s1, the addresses, espeak-ng's en-us), German and Spanish (espeak-ng's ``de``,
  ``es``), noise, and s1 under white noise at 10, 0 and -5 dB SNR;
- ``disagreement.csv``: the rule warning when a given text and the recognized words
  disagree, scored (:mod:`miketalk_lab.bench.disagreement`);
- ``summary.md``: the tables.

Word error rate: (substitutions + deletions + insertions) / reference words, both sides
written as spoken words (:func:`miketalk.speech.recognize.words.spoken_words`: ``F2`` is ``f
two``). Time per minute of speech: the recognizer's seconds over the minutes heard, once on the
clips one by one (Whisper pads each to 30 s) and once on one recording of the clips joined.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio
from miketalk.speech.recognize import get_recognizer, spoken_words
from miketalk.speech.recognize.judge import (
    CONFIDENCE_LIMIT,
    DEFAULT_RECOGNIZER,
    ENGLISH_LIMIT,
    MIN_SPEECH_SECONDS,
)
from miketalk_lab.bench.command import bench_parser, run_bench

RATE = 16000

#: Sentences espeak-ng speaks for the language rule: English, German, Spanish.
ESPEAK = {
    "en-us": (
        "The weather was cold, so we stayed inside and read all afternoon.",
        "Please put the blue box on the table by the window.",
        "Our train leaves at seven, and we must not be late again.",
        "She said the new bridge will open in the spring.",
        "Thank you all for coming here tonight to hear the news.",
        "A good plan today is better than a perfect plan tomorrow.",
    ),
    "de": (
        "Das Wetter war kalt, also blieben wir den ganzen Nachmittag drinnen.",
        "Bitte stell die blaue Kiste auf den Tisch am Fenster.",
        "Unser Zug fährt um sieben Uhr ab, wir dürfen nicht wieder zu spät kommen.",
        "Sie sagte, die neue Brücke wird im Frühling eröffnet.",
        "Vielen Dank, dass Sie heute Abend gekommen sind.",
        "Ein guter Plan heute ist besser als ein perfekter Plan morgen.",
    ),
    "es": (
        "El tiempo estaba frío, así que nos quedamos dentro toda la tarde.",
        "Por favor, pon la caja azul sobre la mesa junto a la ventana.",
        "Nuestro tren sale a las siete y no podemos llegar tarde otra vez.",
        "Ella dijo que el nuevo puente se abrirá en la primavera.",
        "Muchas gracias a todos por venir esta noche.",
        "Un buen plan hoy es mejor que un plan perfecto mañana.",
    ),
}

#: SNRs (dB) of s1's speech under white noise.
SNRS = (10.0, 0.0, -5.0)


def word_errors(reference: Sequence[str], hypothesis: Sequence[str]) -> int:
    """Substitutions + deletions + insertions turning ``reference`` into ``hypothesis``."""
    previous = list(range(len(hypothesis) + 1))
    for i, ref in enumerate(reference, 1):
        current = [i]
        for j, hyp in enumerate(hypothesis, 1):
            current.append(min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (ref != hyp)))
        previous = current
    return previous[-1]


def read_pool(folder: Path, pattern: str) -> list[tuple[str, Path, str]]:
    """``(id, media, transcript)`` of each clip of a folder with ``transcripts.txt``."""
    try:
        lines = (folder / "transcripts.txt").read_text("utf-8").splitlines()
    except OSError as err:
        raise MiketalkError(f"cannot read {folder / 'transcripts.txt'}: {err.strerror}") from err
    out = []
    for line in lines:
        if line.strip():
            clip, _, text = line.partition(" ")
            out.append((clip, folder / "video" / pattern.format(id=clip), text))
    return sorted(out)


class Pocketsphinx:
    """pocketsphinx's default US-English decoder (its wheel's acoustic and language model)."""

    def __init__(self) -> None:
        from pocketsphinx import Decoder

        self.decoder = Decoder(loglevel="FATAL")

    def text(self, samples: np.ndarray) -> str:
        """The words it hears in int16 samples at :data:`RATE`."""
        self.decoder.start_utt()
        self.decoder.process_raw(samples.astype(np.int16).tobytes(), full_utt=True)
        self.decoder.end_utt()
        hyp = self.decoder.hyp()
        return hyp.hypstr if hyp is not None else ""


def hear_pools(pools: dict[str, list[tuple[str, Path, str]]]) -> pd.DataFrame:
    """One row per clip and recognizer (Whisper base, pocketsphinx)."""
    whisper, sphinx = get_recognizer(DEFAULT_RECOGNIZER), Pocketsphinx()
    whisper.hear(np.zeros(RATE, np.int16), RATE)  # load once, outside the timing
    rows = []
    for pool, clips in pools.items():
        for clip, media, text in clips:
            samples = read_media_audio(media, rate=RATE)
            reference = spoken_words(text)
            t0 = time.perf_counter()
            heard = whisper.hear(samples, RATE)
            t1 = time.perf_counter()
            sphinx_text = sphinx.text(samples)
            t2 = time.perf_counter()
            for name, hypothesis, seconds, extra in (
                (DEFAULT_RECOGNIZER, heard.text, t1 - t0,
                 {"english": heard.english, "confidence": heard.mean_probability,
                  "language": heard.language, "speech_s": heard.speech_seconds}),
                ("pocketsphinx", sphinx_text, t2 - t1, {}),
            ):  # fmt: skip
                words = spoken_words(hypothesis)
                rows.append(
                    {"pool": pool, "clip": clip, "recognizer": name,
                     "reference": " ".join(reference), "hypothesis": " ".join(words),
                     "ref_words": len(reference), "errors": word_errors(reference, words),
                     "audio_s": len(samples) / RATE, "seconds": seconds} | extra
                )  # fmt: skip
    return pd.DataFrame(rows)


def joined_speed(clips: list[tuple[str, Path, str]], seconds: float = 60.0) -> dict[str, float]:
    """Whisper's seconds per minute of speech on one recording of clips joined (about a minute)."""
    parts, total = [], 0
    for _, media, _ in clips:
        parts.append(read_media_audio(media, rate=RATE))
        total += len(parts[-1])
        if total >= seconds * RATE:
            break
    samples = np.concatenate(parts)
    recognizer = get_recognizer(DEFAULT_RECOGNIZER)
    t0 = time.perf_counter()
    recognizer.hear(samples, RATE)
    took = time.perf_counter() - t0
    return {"joined_audio_s": len(samples) / RATE, "joined_seconds": took,
            "joined_seconds_per_minute": took / (len(samples) / RATE / 60)}  # fmt: skip


def espeak(voice: str, text: str, folder: Path) -> np.ndarray:
    """espeak-ng's ``voice`` speaking ``text``, int16 at :data:`RATE`."""
    exe = shutil.which("espeak-ng")
    if exe is None:
        raise MiketalkError("espeak-ng not found: apt-get install -y espeak-ng")
    wav = folder / "espeak.wav"
    subprocess.run([exe, "-v", voice, "-w", str(wav), text], check=True, capture_output=True)
    return read_media_audio(wav, rate=RATE)


def rule_cases(
    pool: list[tuple[str, Path, str]], snr_clips: int = 10
) -> list[tuple[str, str, np.ndarray]]:
    """``(kind, id, samples)`` of the language/noise rule's cases beyond the pools (which
    :func:`hear_pools` hears): espeak-ng's voices, noise, s1 under noise."""
    rng = np.random.default_rng(0)
    cases: list[tuple[str, str, np.ndarray]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for voice, texts in ESPEAK.items():
            cases += [(f"espeak {voice}", str(i), espeak(voice, t, Path(tmp)))
                      for i, t in enumerate(texts)]  # fmt: skip
    for seconds in (3.0, 10.0):
        n = int(seconds * RATE)
        white = rng.normal(0, 3000, n)
        brown = np.cumsum(rng.normal(0, 1, n))
        brown = (brown - np.convolve(brown, np.ones(801) / 801, "same")) * 3000 / brown.std()
        hum = 2000 * np.sin(2 * np.pi * 50 * np.arange(n) / RATE) + rng.normal(0, 200, n)
        for name, noise in (("white", white), ("brown", brown), ("hum", hum)):
            cases.append(("noise", f"{name} {seconds:.0f}s", _int16(noise)))
    step = max(1, len(pool) // snr_clips)
    for clip, media, _ in pool[::step][:snr_clips]:
        speech = read_media_audio(media, rate=RATE).astype(np.float64)
        power = np.mean(speech**2)
        for snr in SNRS:
            noise = rng.normal(0, np.sqrt(power / 10 ** (snr / 10)), len(speech))
            cases.append((f"s1 at {snr:+.0f} dB", clip, _int16(speech + noise)))
    return cases


def _int16(x: np.ndarray) -> np.ndarray:
    return np.clip(np.round(x), -32768, 32767).astype(np.int16)


def verdict(speech: float, english: float, confidence: float) -> str:
    """The rule's verdict (:func:`miketalk.speech.recognize.judge.judge`)."""
    if speech < MIN_SPEECH_SECONDS:
        return "no speech"
    if english < ENGLISH_LIMIT:
        return "not English"
    return "unsure" if confidence < CONFIDENCE_LIMIT else "speech"


def rule_table(cases: list[tuple[str, str, np.ndarray]], heard: pd.DataFrame) -> pd.DataFrame:
    """What the rule sees on each case (the pools' clips as :func:`hear_pools` heard them)."""
    recognizer = get_recognizer(DEFAULT_RECOGNIZER)
    pools = heard[heard.recognizer == DEFAULT_RECOGNIZER]
    rows = [{"kind": r.pool, "clip": r.clip, "language": r.language, "english": r.english,
             "confidence": r.confidence, "speech_s": r.speech_s, "words": len(r.hypothesis.split()),
             "text": r.hypothesis} for r in pools.itertuples()]  # fmt: skip
    for kind, clip, samples in cases:
        got = recognizer.hear(samples, RATE)
        rows.append({"kind": kind, "clip": clip, "language": got.language,
                     "english": got.english, "confidence": got.mean_probability,
                     "speech_s": got.speech_seconds,
                     "words": len(got.words), "text": got.text})  # fmt: skip
    table = pd.DataFrame(rows)
    return table.assign(
        verdict=[
            verdict(*v) for v in zip(table.speech_s, table.english, table.confidence, strict=True)
        ]
    )


def summary(heard: pd.DataFrame, rule: pd.DataFrame, speed: dict[str, float]) -> str:
    """The tables of ``summary.md``."""
    lines = [
        "# The speech recognizer",
        "",
        "Word error rate against the transcripts (GRID s1: exact; the weekly addresses: their "
        "caption lines, approximate: some hold words their clip does not, so their WER is an "
        "upper bound), and seconds of recognition per minute of speech.",
        "",
        "| pool | recognizer | clips | words | WER | clips exact | s per min of speech |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (pool, name), g in heard.groupby(["pool", "recognizer"], sort=False):
        lines.append(
            f"| {pool} | {name} | {len(g)} | {g.ref_words.sum()} | "
            f"{g.errors.sum() / g.ref_words.sum():.3f} | {(g.errors == 0).mean():.2f} | "
            f"{g.seconds.sum() / (g.audio_s.sum() / 60):.1f} |"
        )
    lines += [
        "",
        f"One recording of s1 clips joined ({speed['joined_audio_s']:.0f} s): "
        f"{speed['joined_seconds']:.1f} s, {speed['joined_seconds_per_minute']:.1f} s per "
        "minute of speech.",
        "",
        f"## The language and noise rule (under {MIN_SPEECH_SECONDS} s of speech by the voice "
        f"detector: no speech; English under {ENGLISH_LIMIT:.2f}: another language; mean word "
        f"confidence under {CONFIDENCE_LIMIT:.2f}: unsure, too noisy or unclear)",
        "",
        "| kind | cases | English p: min | median | confidence: min | median | speech | "
        "no speech | not English | unsure |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for kind, g in rule.groupby("kind", sort=False):
        counts = g.verdict.value_counts()
        lines.append(
            f"| {kind} | {len(g)} | {g.english.min():.2f} | {g.english.median():.2f} | "
            f"{g.confidence.min():.2f} | {g.confidence.median():.2f} | "
            f"{counts.get('speech', 0)} | {counts.get('no speech', 0)} | "
            f"{counts.get('not English', 0)} | {counts.get('unsure', 0)} |"
        )
    return "\n".join(lines) + "\n"


def measure(pool: Path, addresses: Path, out: Path, limit: int | None = None) -> str:
    """Hear both pools, run the rule's cases, write ``out``'s tables; the summary."""
    clips = read_pool(pool, "{id}.mpg")
    clips = clips[:: -(-len(clips) // limit)] if limit else clips  # spread over the pool
    talks = read_pool(addresses, "{id}.mp4")
    out.mkdir(parents=True, exist_ok=True)
    heard = hear_pools({"s1": clips, "addresses": talks})
    heard.to_csv(out / "heard.csv", index=False)
    speed = joined_speed(clips)
    rule = rule_table(rule_cases(clips), heard)
    rule.to_csv(out / "rule.csv", index=False)
    from miketalk_lab.bench.disagreement import measure as disagreement

    text = summary(heard, rule, speed) + "\n" + disagreement(out / "heard.csv", out)
    (out / "summary.md").write_text(text, "utf-8")
    return text


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (module docstring)."""
    parser: argparse.ArgumentParser = bench_parser(__name__, __doc__, limit_help="s1 clips")
    parser.add_argument("--pool", type=Path, required=True, help="GRID-style pool (s1)")
    parser.add_argument("--addresses", type=Path, required=True, help="the weekly addresses")
    parser.add_argument("--out", type=Path, required=True)
    return run_bench(parser, argv, lambda a: measure(a.pool, a.addresses, a.out, a.limit))


if __name__ == "__main__":
    raise SystemExit(main())
