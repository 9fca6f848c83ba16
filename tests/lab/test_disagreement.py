"""The disagreement rule's bench (miketalk_lab.bench.disagreement) on a heard table made here."""

from __future__ import annotations

import pandas as pd

from miketalk_lab.bench.disagreement import OTHER, disagreement_summary, disagreement_table


def test_each_clip_is_scored_against_its_own_text_and_another() -> None:
    texts = [f"bin blue at {letter} two now" for letter in "abcdefghij"]
    texts[(0 + OTHER) % len(texts)] = "place red by x eight soon please"
    heard = pd.DataFrame({
        "pool": "s1", "clip": [f"c{i}" for i in range(10)], "recognizer": "whisper-base",
        "reference": texts, "hypothesis": texts,
    })  # fmt: skip
    table = disagreement_table(heard)
    assert len(table) == 20
    right = table[table["kind"] == "right"]["disagreement"]
    assert (right == 0).all()
    wrong = table[(table["kind"] == "wrong") & (table["clip"] == "c0")]["disagreement"]
    assert float(wrong.iloc[0]) > 0.5  # another sentence: warned about
    text = disagreement_summary(table)
    assert "| s1 | right | 10 | 0.00 |" in text and "0 of 10 |" in text
