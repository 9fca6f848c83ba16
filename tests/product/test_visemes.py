"""The phone -> viseme table and the paper's corpus."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from miketalk.errors import MiketalkError
from miketalk.visemes import VISEMES, VisemeTable, default_table


def test_corpus_has_the_papers_52_targets_and_16_visemes() -> None:
    table = default_table()
    classes = Counter(t.klass for t in table.targets)
    assert classes == {"consonant": 24, "monophthong": 12, "diphthong": 16, "silence": 1}
    assert set(table.visemes) == set(VISEMES) and len(VISEMES) == 16
    groups = Counter(t.viseme for t in table.targets if t.klass == "consonant")
    assert len(groups) == 6
    mono = {t.viseme for t in table.targets if t.klass == "monophthong"}
    assert len(mono) == 7
    assert {t.viseme for t in table.targets if t.klass == "diphthong"} - mono == {"w-au", "o-ou"}


def test_each_target_names_its_phone_in_its_word() -> None:
    for t in default_table().targets:
        assert t.phone in default_table().phones
        if t.klass in ("consonant", "monophthong"):
            assert default_table().visemes_of(t.phone) == (t.viseme,)


@pytest.mark.parametrize(
    ("phone", "visemes", "word"),
    [
        ("b", ("p",), "bite"),
        ("m", ("p",), "might"),
        ("v", ("f",), "veal"),
        ("ow", ("o-ou", "u"), "boat"),
        ("aw", ("aa", "w-au"), "bout"),
        ("ay", ("aa", "ii"), "bide"),
        ("pau", ("#",), "-"),
        ("dx", ("t",), "tea"),
    ],
)
def test_phone_lookup(phone: str, visemes: tuple[str, ...], word: str) -> None:
    table = default_table()
    assert table.visemes_of(phone) == visemes
    assert table.word_of(phone) == word


def test_every_diphthong_phone_maps_to_two_visemes() -> None:
    table = default_table()
    for phone in ("ow", "ey", "aw", "ay", "oy"):
        assert len(table.visemes_of(phone)) == 2


def test_unknown_phone_is_a_clear_error() -> None:
    with pytest.raises(MiketalkError, match="unknown phone 'qq'"):
        default_table().visemes_of("qq")


def test_grouping_can_be_configured() -> None:
    table = VisemeTable(grouping={"th": "f", "dh": "f"})
    assert table.visemes_of("th") == ("f",)
    with pytest.raises(MiketalkError, match="unknown corpus targets"):
        VisemeTable(grouping={"nope": "f"})


def test_representatives() -> None:
    table = default_table()
    assert table.representative("p").key == "p"
    assert table.representative("w-au").key == "au:2"
    assert table.representative("#").klass == "silence"


def test_bad_table_file(tmp_path: Path) -> None:
    with pytest.raises(MiketalkError, match="cannot read"):
        VisemeTable(corpus_tsv=tmp_path / "missing.tsv")
