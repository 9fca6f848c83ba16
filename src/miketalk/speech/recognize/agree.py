"""Whether a given text and the words recognized in its recording say the same thing.

With ``--phones recognized`` and a text given, the phones come from the recognized words, and
the text is compared with them: :func:`disagreement` is the character edit distance between
the two as spoken words (spaces left out, so ``bimble`` against ``bin blue`` costs 2 letters
of 7, not 2 words of 2), over the text's letters. Above :data:`DISAGREEMENT_LIMIT` one of the
two is not what the recording says, and :func:`warn_disagreement` says so.

The limit, measured (docs/recognize.md, "The disagreement rule"; Whisper base on 100 GRID s1
sentences, each against its own transcript and against another sentence's): its own text
0.18 on average (0.48 at the 95th percentile), another sentence's 0.78 (0.52 at the 5th); at
0.5, 3 of the 100 right texts are warned about and 95 of the 100 wrong ones.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

log = logging.getLogger(__name__)

#: Above this :func:`disagreement`, a given text and the recognized words are warned about.
DISAGREEMENT_LIMIT = 0.5


def edit_distance(a: Sequence, b: Sequence) -> int:
    """Levenshtein distance between two sequences (one numpy row per item of ``a``)."""
    if not a or not b:
        return max(len(a), len(b))
    codes = {item: k for k, item in enumerate(dict.fromkeys([*a, *b]))}
    bb = np.array([codes[item] for item in b])
    steps = np.arange(len(b) + 1)
    row = steps.copy()
    for i, item in enumerate(a, 1):
        # substitution or match from the row above, deletion from above; insertion (from
        # the left) as a running minimum: row[j] = min_k<=j (x[k] + j - k)
        x = np.empty_like(row)
        x[0] = i
        x[1:] = np.minimum(row[:-1] + (bb != codes[item]), row[1:] + 1)
        row = np.minimum.accumulate(x - steps) + steps
    return int(row[-1])


def disagreement(given: Sequence[str], heard: Sequence[str]) -> float:
    """The character edit distance between two word lists (spaces left out), over the
    letters of ``given`` (0: the same; 1 or more: nothing in common)."""
    a, b = "".join(given), "".join(heard)
    return edit_distance(a, b) / max(len(a), 1)


def warn_disagreement(source: object, given: Sequence[str], heard: Sequence[str]) -> float:
    """Warn (logging, so on stderr) when ``given`` and ``heard`` disagree beyond
    :data:`DISAGREEMENT_LIMIT`; the :func:`disagreement`."""
    share = disagreement(given, heard)
    if share > DISAGREEMENT_LIMIT:
        log.warning(
            "%s: the recognized words (%s) and the text given (%s) disagree (%.0f%% of its "
            "letters differ, over %.0f%%): the phones follow the recognized words; is the text "
            "this recording's?",
            source, _short(heard), _short(given), 100 * share, 100 * DISAGREEMENT_LIMIT,
        )  # fmt: skip
    return share


def _short(words: Sequence[str]) -> str:
    said = " ".join(words)
    return said if len(said) <= 60 else said[:57] + "..."
