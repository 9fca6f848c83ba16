"""Anchors of the long aligner (:mod:`miketalk.speech.long_anchor`): a recogniser biased to the
script finds runs of its words, and the long aligner places a script whose lines run past
their clips (:func:`miketalk.speech.long_align.align_long`), on GRID clips of ``data/grid_s1``
joined at test time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from miketalk.corpus.script import Cue
from miketalk.corpus.script_fit import judge, measure_fit, trusted
from miketalk.media.decode import read_media_audio
from miketalk.speech.align.phones import FIT_LIMIT
from miketalk.speech.long_align import align_long
from miketalk.speech.long_anchor import anchors, heard_words, transcript_lm

DATA = Path(__file__).resolve().parents[2] / "data" / "grid_s1"
_TEXT = dict(line.split(" ", 1) for line in (DATA / "transcripts.txt").read_text().splitlines())
_IDS = sorted(_TEXT)
#: Twelve clips (36 s), and the clips whose lines lend the extra words.
CLIPS, OTHERS = _IDS[::4], _IDS[2::4]


@pytest.fixture(scope="module")
def joined() -> tuple[np.ndarray, list[float]]:
    """The twelve clips' sound one after the other (16 kHz) and where each begins and ends."""
    sounds = [read_media_audio(DATA / "video" / f"{c}.mpg", rate=16000) for c in CLIPS]
    edges = np.cumsum([0] + [len(s) / 16000 for s in sounds])
    return np.concatenate(sounds), [float(t) for t in edges]


def _longer_lines() -> list[list[str]]:
    """Three lines in four with one to three words of another clip's line at the start or the
    end (as a caption line runs on past its cut)."""
    out = []
    for i, (own, other) in enumerate(zip(CLIPS, OTHERS, strict=True)):
        line, extra, k = _TEXT[own].split(), _TEXT[other].split(), 1 + i % 3
        if i % 4 == 3:
            out.append(line)
        elif (i // 2) % 2:
            out.append([*extra[-k:], *line])
        else:
            out.append([*line, *extra[:k]])
    return out


def test_anchors_are_runs_heard_as_the_script_has_them() -> None:
    script = "bin blue at f two now set white by".split()
    heard = "green bin blue s two now set white by".split()  # a letter misheard
    assert anchors(script, heard) == [(4, 4, 5)]  # "bin blue" is too short a run
    assert anchors(script, heard, min_run=2) == [(0, 1, 2), (4, 4, 5)]
    assert anchors(script, "lay red with".split()) == []


def test_the_language_model_follows_the_script() -> None:
    """Each word's successors in the script, and nothing else, as bigrams; every word a
    unigram."""
    text = transcript_lm("bin blue bin red".split())
    bigrams = text.split("\\2-grams:")[1].split("\\end\\")[0].split("\n")
    pairs = sorted(tuple(line.split()[1:]) for line in bigrams if line.strip())
    assert pairs == [("<s>", "bin"), ("bin", "blue"), ("bin", "red"), ("blue", "bin"),
                     ("red", "</s>")]  # fmt: skip
    assert "ngram 1=5" in text and "ngram 2=5" in text


def test_the_recogniser_hears_a_clip_as_its_line(joined) -> None:
    samples, edges = joined
    script = [w for line in _longer_lines() for w in line]
    heard = heard_words(samples, 16000, (edges[0], edges[2]), script)
    said = (_TEXT[CLIPS[0]] + " " + _TEXT[CLIPS[1]]).split()
    found = anchors(said, [w.word for w in heard])
    assert sum(n for _, _, n in found) >= 10, [w.word for w in heard]
    assert all(edges[0] <= w.start < w.end <= edges[2] for w in heard)


def test_lines_longer_than_their_clips_keep_the_words_said(joined) -> None:
    """The words of another sentence at nine lines' edges are not said: the words that are
    (72) are placed, each in its own clip, and few of the others. Before anchors the first
    pass failed on most of the recording (on 40 such clips, 20 % of the words kept)."""
    samples, edges = joined
    lines = _longer_lines()
    script = [w for line in lines for w in line]
    own = []  # for each word of the script: its clip, or None for an extra word
    for i, line in enumerate(lines):
        said = _TEXT[CLIPS[i]].split()
        start = next(k for k in range(len(line)) if line[k : k + len(said)] == said)
        own += [i if start <= k < start + len(said) else None for k in range(len(line))]
    found = trusted(align_long(samples, 16000, [Cue(tuple(script))], fit_limit=FIT_LIMIT))
    placed = [(own[i], w) for i, w in found.words]
    said = [(clip, w) for clip, w in placed if clip is not None]
    assert len(said) >= 0.9 * 72, found.unaligned
    assert all(edges[clip] - 0.05 <= w.start and w.end <= edges[clip + 1] + 0.05
               for clip, w in said), said  # fmt: skip
    assert len(placed) - len(said) <= 2
    fit = measure_fit(found, [len(line) for line in lines], samples, 16000)
    assert judge(fit, "the joined clips") is None


def test_another_videos_script_is_still_refused(joined) -> None:
    """The twelve clips with the lines of twelve others (the same 51 words and grammar)."""
    samples, _ = joined
    lines = [_TEXT[c].split() for c in _IDS[1::4]]
    script = tuple(w for line in lines for w in line)
    found = trusted(align_long(samples, 16000, [Cue(script)], fit_limit=FIT_LIMIT))
    fit = measure_fit(found, [len(line) for line in lines], samples, 16000)
    assert fit.kept_share < 0.2 and judge(fit, "the joined clips") is not None, fit


def test_a_script_read_over_and_over_is_matched_in_order() -> None:
    """1200 words said six times (as an hour of clips joined over and over), heard with a
    word in twenty missed and one in ten misheard: every anchor lies where it was said (but
    for a word or two at a run's edge, next to a missed word alike).
    (difflib's longest match over the whole took 1671 words for another reading's.)"""
    rng = np.random.default_rng(1)
    vocab = [f"w{i}" for i in range(51)]
    script = list(rng.choice(vocab, 1200)) * 6
    heard, said = [], []  # each heard word, and the word of the script it was
    for i, w in enumerate(script):
        if rng.random() < 0.05:
            continue
        heard.append(w if rng.random() > 0.1 else str(rng.choice(vocab)))
        said.append(i)
    found = anchors(script, heard)
    assert sum(n for _, _, n in found) > 0.8 * len(script)
    off = [abs(said[b + k] - (a + k)) for a, b, n in found for k in range(n)]
    assert max(off) <= 3 and np.mean(np.array(off) > 0) < 0.01  # a word missed in a run
