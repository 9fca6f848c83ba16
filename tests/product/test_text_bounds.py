"""The largest text is bounded: each sentence's work, and the words of one text (issue 50).

A one-line megabyte (the largest file ``say -f`` reads) needed more than 7.7 GB while its
frames were drawn; now the text is refused, before Festival starts, in one line that says
the limit, and every chunk Festival is given stays within its word limit however long the
line. Memory itself is measured in docs/safety.md, not here.
"""

from __future__ import annotations

import pytest

from miketalk.errors import MiketalkError
from miketalk.speech.festival import FestivalBackend
from miketalk.speech.text import (
    MAX_SPOKEN_WORDS,
    check_spoken_length,
    normalize_text,
    split_chunks,
)


def _words(n: int) -> str:
    """``n`` words of a GRID sentence on one line."""
    return " ".join(["bin", "blue", "at", "f", "two", "now"][i % 6] for i in range(n))


def test_a_text_of_the_limit_is_taken_and_one_more_word_refused():
    check_spoken_length(_words(MAX_SPOKEN_WORDS))
    with pytest.raises(MiketalkError, match=f"at most {MAX_SPOKEN_WORDS:,} at a time"):
        check_spoken_length(_words(MAX_SPOKEN_WORDS + 1))


def test_a_one_line_megabyte_is_refused_before_festival_starts():
    text = _words(290_000)  # one line, no sentence end: some 1 MB
    assert len(text) > 1_000_000 and "\n" not in text
    backend = FestivalBackend(executable="/nonexistent/festival")  # never started
    for speak in (backend.start, backend.synthesize):
        with pytest.raises(MiketalkError, match=r"more than 10,000 words.*split it"):
            speak(text)


def test_a_long_line_is_cut_into_bounded_chunks():
    text = normalize_text(_words(2_000))
    chunks = split_chunks(text, max_words=40)
    assert max(len(c.split()) for c in chunks) <= 40
    assert sum(len(c.split()) for c in chunks) == 2_000
