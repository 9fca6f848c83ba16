"""Anchors in a long recording: where a recogniser hears runs of the script's words.

Recursive anchored alignment (Moreno et al. 1998; Gentle does alike): a speech
recogniser whose language model is the script itself (:func:`transcript_lm`: its words,
each word most likely followed by the word after it in the script, any word possible)
decodes the recording in windows cut at quiet frames (:func:`heard_words`, memory by the
window). Its words are matched to the script's (:mod:`difflib`, in order): a run of at
least :data:`ANCHOR_WORDS` words heard as the script has them is an anchor, placed where it
was heard. The script and the sound between two anchors (before the first, after the last)
are then placed by the long aligner's first pass (:func:`anchored_pass`'s ``place``),
which anchors them again with a language model of only their words, and so on: a word of
the script that is not said (a caption line longer than its cut) costs its own stretch,
never the whole recording's alignment.

The recogniser is pocketsphinx with its default beams and no best-path pass (its US English
model ships in the wheel), a dictionary of only the script's words. On 119 s of 40 GRID
clips whose script held 60 words that are not said (lines with extra words), 6.5 s at low
load, 215 of the 240 words said in anchors of three or more words; the long aligner then kept
76 % of the script, not 20 % (``python -m miketalk_lab.bench.script_fit``, with and without
``--halving``; the table in ``docs/build.md``), and scripts of other videos still keep at
most 11 %. On 10 minutes of 200 GRID clips anchored whole (as an hour is), 45 s of the
alignment's 69 s, and 3 of 1200 words unplaced where halving left 104.
"""

from __future__ import annotations

import difflib
import logging
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.speech.word_timings import WordTiming

log = logging.getLogger(__name__)

__all__ = ["ANCHOR_WORDS", "anchored_pass", "anchors", "heard_words", "transcript_lm"]

#: A run of at least this many words heard as the script has them is an anchor.
ANCHOR_WORDS = 3
#: The recogniser decodes windows at most this long (s), each ending at the quietest
#: frame of its last :data:`WINDOW_SLACK` seconds.
WINDOW_SECONDS, WINDOW_SLACK = 30.0, 6.0
#: The heard words are matched to the script this many at a time (:func:`anchors`).
BAND_WORDS = 60
#: An anchor whose offset (its first word's place in the script less its place in the heard
#: words) differs by more than this from both its neighbours', which differ by at most this,
#: is a phrase heard elsewhere in the script (:func:`_in_line`).
SPIKE_WORDS = 10
#: A stretch between anchors with less sound than this (s) a word is widened by a word of
#: each anchor around it (:func:`_roomy`).
WORD_SECONDS = 0.12
#: A stretch between anchors with less sound than this (s) has no room for its words.
MIN_GAP_SECONDS = 0.1
#: The language model: the chance that a word is followed by one that follows it in the
#: script (shared among them); the rest backs off to any word of the script.
FOLLOW = 0.9


def transcript_lm(words: Sequence[str]) -> str:
    """A bigram language model (ARPA text) of ``words`` (the script, in order)."""
    vocab = sorted(set(words))
    counts = {w: 0 for w in vocab}
    for w in words:
        counts[w] += 1
    follow: dict[str, set[str]] = {}
    for a, b in zip(["<s>", *words], [*words, "</s>"], strict=True):
        follow.setdefault(a, set()).add(b)
    total = len(words) + 1
    back = np.log10(1 - FOLLOW)
    unigrams = [f"-99.0000 <s> {back:.4f}", f"{np.log10(1 / total):.4f} </s> 0.0000"]
    unigrams += [f"{np.log10(counts[w] / total):.4f} {w} {back:.4f}" for w in vocab]
    bigrams = [
        f"{np.log10(FOLLOW / len(after)):.4f} {a} {b}"
        for a, after in follow.items()
        for b in sorted(after)
    ]
    head = ["\\data\\", f"ngram 1={len(unigrams)}", f"ngram 2={len(bigrams)}", ""]
    return "\n".join(
        [*head, "\\1-grams:", *unigrams, "", "\\2-grams:", *bigrams, "", "\\end\\", ""]
    )


def heard_words(
    samples: np.ndarray, rate: int, span: tuple[float, float], script: Sequence[str]
) -> list[WordTiming]:
    """The words the recogniser hears in ``span`` of the audio (recording time), its language
    model :func:`transcript_lm` of ``script`` (lower case, words it can pronounce)."""
    from miketalk.speech.align.decoder import _to_pcm
    from miketalk.speech.audio_align import energy_db

    lo, hi = span
    out: list[WordTiming] = []
    with tempfile.TemporaryDirectory() as folder:
        decoder = _recogniser(script, Path(folder))
        for a, b in _windows(samples, rate, lo, hi, energy_db):
            if b - a < MIN_GAP_SECONDS:
                continue
            pcm = _to_pcm(samples[round(a * rate) : round(b * rate)], rate)
            decoder.start_utt()
            decoder.process_raw(pcm.tobytes(), full_utt=True)
            decoder.end_utt()
            frate = int(decoder.config["frate"])
            for s in decoder.seg():
                if s.word.startswith(("<", "[", "+")) or s.word == "sil":
                    continue
                start, end = a + s.start_frame / frate, a + (s.end_frame + 1) / frate
                out.append(WordTiming(s.word.split("(")[0], start, min(end, b)))
            del pcm

    return out


def _recogniser(script: Sequence[str], folder: Path):
    """A recogniser of ``script``'s words: a dictionary of only them (loaded in a few ms,
    where the whole CMU dictionary takes a second or more), :func:`transcript_lm` active."""
    import pocketsphinx

    from miketalk.speech.align.decoder import _LOCK as ALIGN_LOCK
    from miketalk.speech.align.decoder import _shared_aligner
    from miketalk.speech.align.pronounce import extra_arpabet

    vocab = sorted(set(script))
    lines = []
    with ALIGN_LOCK:
        aligner = _shared_aligner()
        extra = extra_arpabet(vocab, aligner)
        for word in vocab:
            if word in extra:
                lines.append(f"{word} {' '.join(extra[word])}")
                continue
            for k in range(1, 10):  # the word and its alternate pronunciations
                name = word if k == 1 else f"{word}({k})"
                phones = aligner.decoder.lookup_word(name)
                if phones is None:
                    break
                lines.append(f"{name} {phones}")
    (folder / "script.dict").write_text("\n".join(lines) + "\n", encoding="utf-8")
    (folder / "script.lm").write_text(transcript_lm(script), encoding="utf-8")
    config = pocketsphinx.Config(
        loglevel="FATAL",
        lm=str(folder / "script.lm"),
        dict=str(folder / "script.dict"),
        bestpath=False,
    )
    try:
        return pocketsphinx.Decoder(config)
    except RuntimeError as err:
        raise MiketalkError(f"the recogniser cannot load the script's words ({err})") from err


def _windows(samples, rate, lo, hi, energy_db) -> list[tuple[float, float]]:
    """``[lo, hi)`` in windows of at most :data:`WINDOW_SECONDS`, cut at quiet frames."""
    out, a = [], lo
    while hi - a > WINDOW_SECONDS:
        first = a + WINDOW_SECONDS - WINDOW_SLACK
        tail = samples[round(first * rate) : round((a + WINDOW_SECONDS) * rate)]
        level = energy_db(tail, rate)
        b = first + 0.01 * int(np.argmin(level)) if level.size else a + WINDOW_SECONDS
        out.append((a, b))
        a = b
    out.append((a, hi))
    return out


def anchors(
    script: Sequence[str], heard: Sequence[str], min_run: int = ANCHOR_WORDS
) -> list[tuple[int, int, int]]:
    """Runs of at least ``min_run`` words heard as ``script`` has them, in order: each
    ``(first word of the script, first heard word, length)``.

    The heard words are matched :data:`BAND_WORDS` at a time (:mod:`difflib`), each time
    to the script from the end of the last run found, no farther than twice the script's
    words per heard word since then (and the band's own words, and 20): a script said twice,
    or a phrase it repeats, is never matched to the wrong one far away (:mod:`difflib`'s
    longest match, over the whole hour of a script read over and over, took the second
    reading's words for the first's).
    """
    ratio = len(script) / max(1, len(heard))
    blocks: list[list[int]] = []
    at, since = 0, 0  # the script's next word after the last run, and its heard word's
    for first in range(0, len(heard), BAND_WORDS):
        end = min(first + BAND_WORDS, len(heard))
        ahead = int(2 * ratio * (end - since)) + BAND_WORDS + 20
        matcher = difflib.SequenceMatcher(
            None, list(script[at : at + ahead]), list(heard[first:end]), autojunk=False
        )
        for m in matcher.get_matching_blocks():
            a, b = at + m.a, first + m.b
            while blocks and blocks[-1][2] < min_run and a < blocks[-1][0] + blocks[-1][2]:
                blocks.pop()  # a short match that is no anchor gives way
            if m.size == 0 or (blocks and a < blocks[-1][0] + blocks[-1][2]):
                continue
            last = blocks[-1] if blocks else None
            if last and last[0] + last[2] == a and last[1] + last[2] == b:
                last[2] += m.size  # a run across two bands
            else:
                blocks.append([a, b, m.size])
        runs = [r for r in blocks if r[2] >= min_run]
        if runs:
            at, since = runs[-1][0] + runs[-1][2], runs[-1][1] + runs[-1][2]
    return _in_line([(a, b, n) for a, b, n in blocks if n >= min_run])


def _in_line(runs: list[tuple[int, int, int]]) -> list[tuple[int, int, int]]:
    """``runs`` (:func:`anchors`) without those out of line with both neighbours: an
    anchor whose offset (script word less heard word) differs by more than
    :data:`SPIKE_WORDS` from both its neighbours', where theirs agree within it.

    A short phrase of a script that repeats its phrases (GRID's "set red with", said some
    forty times an hour) can match the heard words some fifty words ahead in the script
    when the right place is misheard: the words between it and the anchor before are then
    given no sound, and those after it the sound of others. On the hour of GRID clips,
    three such anchors left 131 of the 7200 words unplaced. The words of an anchor left out
    are placed between its neighbours like any others.
    """
    out = list(runs)
    k = 1
    while k < len(out) - 1:
        (a0, b0, _), (a1, b1, _), (a2, b2, _) = out[k - 1], out[k], out[k + 1]
        before, here, after = a0 - b0, a1 - b1, a2 - b2
        if (
            abs(here - before) > SPIKE_WORDS
            and abs(here - after) > SPIKE_WORDS
            and abs(after - before) <= SPIKE_WORDS
        ):
            log.debug("anchor at word %d heard as word %d: out of line, left out", a1, b1)
            del out[k]
            k = max(1, k - 1)
        else:
            k += 1
    return out


def anchored_pass(
    samples: np.ndarray,
    rate: int,
    span: tuple[float, float],
    indices: list[int],
    words: Sequence[str],
    place: Callable[[float, float, list[int]], list[tuple[int, WordTiming]]],
    missing: Callable[[list[int], str], None],
) -> list[tuple[int, WordTiming]] | None:
    """The words ``indices`` of the script ``words`` placed in ``span``: the anchors' words
    where they were heard, the words between them by ``place(lo, hi, indices)``; those
    between anchors with no sound between them reported to ``missing(indices, why)``. None
    when the recogniser hears no anchor."""
    lo, hi = span
    script = [words[i] for i in indices]
    try:
        heard = heard_words(samples, rate, span, script)
    except MiketalkError as err:  # the first pass halves the piece instead
        log.info("no anchors in %.2f..%.2f s: %s", lo, hi, err)
        return None
    found = _roomy(anchors(script, [w.word for w in heard]), heard, len(script), span)
    if not found:
        return None
    log.debug(
        "%d anchors of %d words in %.2f..%.2f s (%d words)",
        len(found), sum(n for _, _, n in found), lo, hi, len(script),
    )  # fmt: skip
    out: list[tuple[int, WordTiming]] = []
    at, after = 0, lo  # the next word of the script not placed, and where its sound begins
    for a, b, n in [*found, (len(script), len(heard), 0)]:
        before = heard[b].start if n else hi
        gap = indices[at:a]
        if gap and before - after >= MIN_GAP_SECONDS:
            out += place(after, before, gap)
        elif gap:
            missing(gap, f"there is no sound between the words around it ({after:.2f} s)")
        for k in range(n):
            w = heard[b + k]
            out.append((indices[a + k], WordTiming(script[a + k], w.start, w.end)))
        if n:
            at, after = a + n, heard[b + n - 1].end
    return out


def _roomy(found, heard: Sequence[WordTiming], count: int, span: tuple[float, float]):
    """``found`` (:func:`anchors`), each stretch between two of them with less sound than
    :data:`WORD_SECONDS` a word of the script in it given the anchors' words next to it.

    The recogniser's edges of a word are rough, and it may miss a short word (a letter) or
    hear one word where the script has two alike (a line's extra "bin" before the next
    line's "bin"): the anchors then close in on words left with no sound. Their neighbours
    in the anchors are placed with them instead, by the first pass, which can drop any.
    """
    runs = [list(r) for r in found]
    for k in range(len(runs) + 1):
        left = runs[k - 1] if k > 0 else None
        right = runs[k] if k < len(runs) else None
        words = (right[0] if right else count) - (left[0] + left[2] if left else 0)
        start = heard[left[1] + left[2] - 1].end if left else span[0]
        end = heard[right[1]].start if right else span[1]
        if words == 0 or end - start >= WORD_SECONDS * words:
            continue
        if left and left[2] > 1:
            left[2] -= 1
        if right and right[2] > 1:
            right[0], right[1], right[2] = right[0] + 1, right[1] + 1, right[2] - 1
    return [tuple(r) for r in runs]
