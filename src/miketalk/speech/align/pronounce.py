"""Pronunciations for the aligner: the ARPAbet <-> Festival phone table and Festival's lexicon.

The aligner's model speaks ARPAbet; miketalk names phones in Festival's radio set
(``voice_kal_diphone``). Words the CMU dictionary lacks are pronounced by Festival
itself (:func:`festival_pronunciations`, one run of ``festival`` for all of them;
the words reach it through a file, never spliced into Scheme).
"""

from __future__ import annotations

import csv
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path

from miketalk.errors import MiketalkError
from miketalk.speech.align.decoder import _Aligner

#: Words reach Festival and pocketsphinx only if spelled with these characters
#: (the characters of the CMU dictionary's words).
_WORD = re.compile(r"[a-z0-9'.\-]+")


_FESTIVAL_HINT = "install it with: apt-get install -y festival festvox-kallpc16k"


@dataclass(frozen=True)
class ArpabetTable:
    """ARPAbet <-> Festival radio phones, read from ``data/arpabet_festival.tsv``.

    Attributes
    ----------
    to_festival : mapping of str to str
        Each ARPAbet phone (and the aligner's ``SIL`` and fillers) to one Festival phone.
    from_festival : mapping of str to tuple of str
        Each Festival radio phone to its ARPAbet spelling: one phone, two for
        Festival's syllabic consonants (``el`` -> ``AH L``), or ``SIL``.
    """

    to_festival: Mapping[str, str]
    from_festival: Mapping[str, tuple[str, ...]]


@cache
def arpabet_table() -> ArpabetTable:
    """The packaged ARPAbet <-> Festival table.

    Raises
    ------
    MiketalkError
        If the table is malformed (an unknown direction, a phone mapped twice).
    """
    text = resources.files("miketalk.data").joinpath("arpabet_festival.tsv").read_text("utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    to_festival: dict[str, str] = {}
    from_festival: dict[str, tuple[str, ...]] = {}
    for row in csv.DictReader(lines, delimiter="\t"):
        arpabet, festival, direction = row["arpabet"].split(), row["festival"], row["direction"]
        if direction not in ("both", "to_festival", "from_festival"):
            raise MiketalkError(f"arpabet_festival.tsv: unknown direction {direction!r}")
        if direction in ("both", "to_festival"):
            if len(arpabet) != 1 or arpabet[0] in to_festival:
                raise MiketalkError(f"arpabet_festival.tsv: bad to-Festival row {row}")
            to_festival[arpabet[0]] = festival
        if direction in ("both", "from_festival"):
            if festival in from_festival:
                raise MiketalkError(f"arpabet_festival.tsv: {festival!r} mapped twice")
            from_festival[festival] = tuple(arpabet)
    return ArpabetTable(to_festival, from_festival)


def _check_word(word: str) -> str:
    """``word`` in lower case, or a MiketalkError naming it."""
    if not isinstance(word, str):
        raise MiketalkError(f"a word must be a string, got {word!r}")
    clean = word.strip().lower()
    if not _WORD.fullmatch(clean) or not any(ch.isalnum() for ch in clean):
        raise MiketalkError(
            f"cannot pronounce the word {word!r}: a word is letters a-z, digits, "
            "apostrophes, periods and hyphens (normalise the text first)"
        )
    return clean


_FESTIVAL_CACHE: dict[tuple[str, str], tuple[str, ...]] = {}


def festival_pronunciations(
    words: Iterable[str], *, executable: str | None = None, timeout: float = 120.0
) -> dict[str, list[str]]:
    """Festival's pronunciation of each word, in radio phones (``voice_kal_diphone``).

    One ``festival`` run looks every word up in the voice's lexicon (CMU-based),
    with Festival's letter-to-sound rules for words it lacks. The words reach
    Festival in a file named by an environment variable and are read as string
    data: they are never part of a Scheme expression or a shell command.

    Parameters
    ----------
    words : iterable of str
        Words (letters, digits, apostrophes, periods, hyphens; any case).
    executable : str, optional
        Path to ``festival``; else ``$MIKETALK_FESTIVAL``; else ``festival`` on PATH.
    timeout : float
        Seconds Festival may take.

    Returns
    -------
    dict of str to list of str
        Each distinct word, lower-cased, to its phones (e.g. ``"hello"`` ->
        ``["hh", "ax", "l", "ow"]``).

    Raises
    ------
    MiketalkError
        A word spelled with other characters, Festival missing or failing, or
        Festival giving a word no phones (the message names the word).
    """
    clean = list(dict.fromkeys(_check_word(w) for w in words))
    if not clean:
        return {}
    exe = executable or os.environ.get("MIKETALK_FESTIVAL") or "festival"
    return _run_festival_lexicon(clean, exe, timeout)


def _run_festival_lexicon(
    words: list[str], executable: str, timeout: float
) -> dict[str, list[str]]:
    path = shutil.which(executable)
    if path is None:
        raise MiketalkError(f"Festival not found ({executable!r}); {_FESTIVAL_HINT}")
    scheme = resources.files("miketalk.speech").joinpath("scheme/lexicon.scm")
    with (
        tempfile.TemporaryDirectory(prefix="miketalk-lexicon-") as tmp,
        resources.as_file(scheme) as scheme_path,
    ):
        words_file, out_file = Path(tmp, "words.scm"), Path(tmp, "pronunciations.txt")
        # the words were checked against _WORD: no quote or backslash can end a string early
        words_file.write_text("(" + " ".join(f'"{w}"' for w in words) + ")\n", "utf-8")
        env = {
            "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
            "HOME": tmp,
            "MIKETALK_WORDS": str(words_file),
            "MIKETALK_OUT": str(out_file),
        }
        command = [path, "--heap", "1000000", "-b", str(scheme_path)]
        try:
            proc = subprocess.run(
                command, env=env, cwd=tmp, capture_output=True, text=True, timeout=timeout
            )
        except subprocess.TimeoutExpired:
            raise MiketalkError(f"Festival took longer than {timeout:.0f} s") from None
        messages = (proc.stderr + proc.stdout).strip()
        if proc.returncode != 0 or "SIOD ERROR" in messages or not out_file.is_file():
            if "voice_kal_diphone" in messages and "unbound" in messages:
                raise MiketalkError(f"Festival's kal voice is missing; {_FESTIVAL_HINT}")
            tail = "\n".join(messages.splitlines()[-5:])
            raise MiketalkError(f"Festival failed (exit {proc.returncode}):\n{tail}")
        lines = out_file.read_text("utf-8").splitlines()
    if len(lines) != len(words):
        raise MiketalkError(f"Festival pronounced {len(lines)} of {len(words)} words")
    known = arpabet_table().from_festival
    result = {}
    for word, line in zip(words, lines, strict=True):
        name, _, phones = line.partition("\t")
        phones_list = phones.split()
        if name != word or not phones_list:
            raise MiketalkError(f"Festival gave no pronunciation of the word {word!r}")
        unknown = [p for p in phones_list if p not in known]
        if unknown:
            raise MiketalkError(f"Festival pronounced {word!r} with unknown phones {unknown}")
        result[word] = phones_list
    return result


def _pronunciations(
    words: Sequence[str], aligner: _Aligner, pronounce: Callable[[str], Sequence[str]] | None
) -> dict[str, tuple[str, ...]]:
    """Festival-phone pronunciations of the words the CMU dictionary lacks."""
    missing = [w for w in dict.fromkeys(words) if not aligner.in_dictionary(w)]
    if not missing:
        return {}
    if pronounce is None:
        exe = os.environ.get("MIKETALK_FESTIVAL") or "festival"
        return _festival_lookup(missing, exe)
    silent = {f for f, arpa in arpabet_table().from_festival.items() if arpa == ("SIL",)}
    result = {}
    for word in missing:
        phones = tuple(str(p) for p in pronounce(word) if str(p) not in silent)
        if not phones:
            raise MiketalkError(f"no pronunciation of the word {word!r}")
        result[word] = phones
    return result


def extra_arpabet(
    words: Sequence[str],
    aligner: _Aligner,
    pronounce: Callable[[str], Sequence[str]] | None = None,
) -> dict[str, tuple[str, ...]]:
    """The ARPAbet pronunciations of the words ``aligner``'s dictionary lacks (from Festival,
    or ``pronounce``), to add to it. The caller holds the aligner's lock."""
    return {w: _to_arpabet(w, p) for w, p in _pronunciations(words, aligner, pronounce).items()}


def _festival_lookup(words: list[str], executable: str) -> dict[str, tuple[str, ...]]:
    """Festival's pronunciations, from one run for the words not looked up before.

    Kept for the process: Festival's lexicon does not change while it runs.
    """
    todo = [w for w in words if (w, executable) not in _FESTIVAL_CACHE]
    if todo:
        found = _run_festival_lexicon(todo, executable, 120.0)
        for word in todo:
            _FESTIVAL_CACHE[(word, executable)] = tuple(found[word])
    return {w: _FESTIVAL_CACHE[(w, executable)] for w in words}


def _to_arpabet(word: str, festival: Sequence[str]) -> tuple[str, ...]:
    table = arpabet_table().from_festival
    arpabet: list[str] = []
    for phone in festival:
        if phone not in table:
            raise MiketalkError(
                f"the pronunciation of {word!r} has {phone!r}, not a Festival radio phone"
            )
        if table[phone] == ("SIL",):
            raise MiketalkError(f"the pronunciation of {word!r} has the silence {phone!r}")
        arpabet += table[phone]
    return tuple(arpabet)


def _festival_names(
    word: str, phones: list[tuple[str, float, float]], festival: Sequence[str] | None
) -> list[tuple[str, float, float]]:
    """A word's aligned ARPAbet phones under Festival's names.

    A word pronounced in Festival phones gets them back (two ARPAbet phones
    joined again for ``el``, ``em``, ``en``); others go through the table.
    """
    table = arpabet_table()
    if festival is not None:
        sizes = [len(table.from_festival[f]) for f in festival]
        if sum(sizes) == len(phones):
            named, i = [], 0
            for name, size in zip(festival, sizes, strict=True):
                named.append((name, phones[i][1], phones[i + size - 1][2]))
                i += size
            return named
    out = []
    for name, start, end in phones:
        if name not in table.to_festival:
            raise MiketalkError(f"the aligner gave {word!r} the unknown phone {name!r}")
        out.append((table.to_festival[name], start, end))
    return out
