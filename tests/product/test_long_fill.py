"""The long aligner's last pass (:mod:`miketalk.speech.long_fill`): the words it left out
aligned again between the words placed around them; and anchors out of line with their
neighbours left out (:mod:`miketalk.speech.long_anchor`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from miketalk.corpus.script import Cue
from miketalk.corpus.script_fit import trusted
from miketalk.media.decode import read_media_audio
from miketalk.speech.align.phones import FIT_LIMIT
from miketalk.speech.long_align import Unaligned, align_long
from miketalk.speech.long_anchor import anchors
from miketalk.speech.long_fill import SHORT_STRETCH, fill_gaps, regions
from miketalk.speech.word_timings import WordTiming


def _part(indices: list[int], start: float) -> tuple:
    """A part of words ``w<i>``, 0.3 s each from ``start``."""
    spans = [
        WordTiming(f"w{i}", start + 0.3 * k, start + 0.3 * (k + 1)) for k, i in enumerate(indices)
    ]
    return ((start, spans[-1].end), list(zip(indices, spans, strict=True)), spans, [], -10.0)


def test_regions_are_each_gap_and_each_short_run_with_the_part_either_side() -> None:
    parts = [
        _part([0, 1, 2, 3, 4, 5], 0.0),
        _part([8, 9], 3.0),  # a gap before it (6, 7), a run of 2 words, a gap after (10, 11)
        _part([12, 13, 14, 15, 16, 17], 4.0),
        _part([18, 19, 20, 21, 22, 23], 6.0),
    ]
    assert SHORT_STRETCH > 2
    assert regions(parts, 24) == [(0, 1), (0, 2), (1, 2)]
    assert regions(parts, 27) == [(0, 1), (0, 2), (1, 2), (3, 3)]  # the last words missing
    assert regions(parts[2:], 24) == [(0, 0)]  # the script's first words missing
    assert regions([], 10) == []


def test_a_gap_is_aligned_again_and_kept_only_where_more_words_are_placed() -> None:
    parts = [_part([0, 1], 0.0), _part([2, 3, 4, 5], 1.0), _part([9, 10, 11, 12, 13, 14], 4.0)]
    unaligned = [Unaligned(i, f"w{i}", "cannot be placed") for i in (6, 7, 8)]
    asked = []

    def realign(lo, hi, indices, missing, found=True):
        asked.append((round(lo, 2), round(hi, 2), indices))
        if not found:
            missing += [Unaligned(i, f"w{i}", "not again") for i in indices]
            return []
        return [_part(indices[:9], lo + 0.05), _part(indices[9:], lo + 2.0)]

    # the gap with the part either side (not the words before them), in the sound from the
    # end of the word before them to the end of the recording
    new, left = fill_gaps(parts, unaligned, 15, 10.0, realign)
    assert asked == [(0.6, 10.0, list(range(2, 15)))]
    assert [i for p in new for i, _ in p[1]] == list(range(15)) and left == []
    new, left = fill_gaps(parts, unaligned, 15, 10.0, lambda *a: realign(*a, found=False))
    assert new == parts and left == unaligned  # nothing better: kept as it was
    asked.clear()
    whole = [_part([0, 1, 2, 3, 4, 5], 0.0), parts[2]]  # the gap's region: the whole script
    new, left = fill_gaps(whole, unaligned, 15, 10.0, realign)
    assert asked == [] and new == whole  # the recording's own alignment is not redone


def test_an_anchor_out_of_line_with_its_neighbours_is_left_out() -> None:
    """A phrase of the script misheard where it is said ('q a b' heard 'y a b') and said
    again fifty words on: the band's longest match took the later one, and the words
    between were given no sound (three such anchors left 131 words of the hour of GRID
    clips unplaced)."""
    rng = np.random.default_rng(2)
    script = [str(w) for w in rng.choice([f"w{i}" for i in range(40)], 240)]
    script[56:60], script[107:110] = ["x", "q", "a", "b"], ["y", "a", "b"]
    heard = list(script)
    heard[57] = "y"
    found = anchors(script, heard)
    assert found and all(a == b for a, b, _ in found), found
    assert sum(n for _, _, n in found) > 150


DATA = Path(__file__).resolve().parents[2] / "data" / "grid_s1"


def test_the_joined_clips_place_every_word_their_clips_place_alone() -> None:
    """Sixteen clips of ``data/grid_s1`` joined (48 s), their lines with one to three words of
    another clip's line at three lines in four: every word the long aligner places in a clip
    alone with its line is placed in the joined recording, in a trusted stretch. Without the
    last pass, 5 were not (the first line's first three words, two of the second's)."""
    text = dict(line.split(" ", 1) for line in (DATA / "transcripts.txt").read_text().splitlines())
    ids = sorted(text)
    clips, others = ids[1::3], ids[0::3]
    lines = []
    for i, (own, other) in enumerate(zip(clips, others, strict=True)):
        line, extra, k = text[own].split(), text[other].split(), 1 + i % 3
        if i % 4 == 3:
            lines.append(line)
        else:
            lines.append([*extra[-k:], *line] if (i // 2) % 2 else [*line, *extra[:k]])
    sounds = [read_media_audio(DATA / "video" / f"{c}.mpg", rate=16000) for c in clips]
    alone, first = [], 0
    for sound, line in zip(sounds, lines, strict=True):
        found = align_long(sound, 16000, [Cue(tuple(line))], fit_limit=FIT_LIMIT)
        alone += [first + i for i, _ in found.words]
        first += len(line)
    script = tuple(w for line in lines for w in line)
    joined = trusted(align_long(np.concatenate(sounds), 16000, [Cue(script)], fit_limit=FIT_LIMIT))
    placed = {i for i, _ in joined.words}
    assert len(alone) >= 90
    assert [script[i] for i in alone if i not in placed] == [], joined.unaligned


def _joined(clips: list[str], lines: list[str]):
    """The clips of ``data/grid_s1`` joined: the whole recording's trusted alignment of
    ``lines`` (a plain transcript), the script's words and where each clip starts (s)."""
    sounds = [read_media_audio(DATA / "video" / f"{c}.mpg", rate=16000) for c in clips]
    starts = np.cumsum([0.0] + [len(s) / 16000 for s in sounds])
    words = [tuple(line.split()) for line in lines]
    script = [Cue(tuple(w for line in words for w in line))]
    joined = align_long(np.concatenate(sounds), 16000, script, fit_limit=FIT_LIMIT)
    return trusted(joined), [w for line in words for w in line], starts


def test_a_z_said_zed_is_placed_in_the_joined_clips() -> None:
    """GRID talker 1 says the letter z "zed"; the CMU dictionary has only "zee". With it
    alone the aligner put "z" over the closure of its "d" ("with" over "with z"), left it
    out, and the line's other five words were placed in runs of 2 and 3, not trusted (40
    GRID lines with extra words: 5 words placed clip by clip missed)."""
    found, script, starts = _joined(
        ["lrik4p", "lrwz5a", "lwbs1s"],
        [
            "lay red in k four please bin green",
            "lay red with z five again bin blue in",
            "please lay white by s one soon",
        ],
    )
    placed = {i: w for i, w in found.words}
    assert [script[i] for i in range(8, 14) if i in placed] == "lay red with z five again".split()
    z = placed[11]  # GRID's own alignment: 1.31..1.72 s of its clip
    assert z.start < starts[1] + 1.40 and z.end > starts[1] + 1.65, z
