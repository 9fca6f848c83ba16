"""Phones to visemes: the paper's corpus (Figure 3) and its 16-viseme grouping (section 4).

Two tables, kept as package data so they can be read and edited without code:

``data/phones.tsv``
    Festival's radio phone -> the paper's phonemic label.
``data/corpus.tsv``
    One row per target nucleus of the recorded corpus (52, plus silence): the
    corpus word, Festival's pronunciation of it, which phone carries the target,
    and the viseme the target is grouped into. A diphthong label has two rows
    (``LABEL:1``, ``LABEL:2``), so a diphthong phone maps to two visemes.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path

from miketalk.errors import MiketalkError

#: The 16 visemes in canonical order: 6 consonant, 7 monophthong, the two
#: diphthong-only nuclei \w-au\ and \o-ou\, and silence.
VISEMES: tuple[str, ...] = (
    "p", "f", "t", "w", "ch", "k",
    "ii", "e", "aa", "uh", "oo", "u", "uu",
    "w-au", "o-ou",
    "#",
)  # fmt: skip

SILENCE = "#"


_SAFE = frozenset("abcdefghijklmnopqrstuvwxyz0123456789")


def viseme_slug(name: str) -> str:
    """A file-name-safe, one-to-one spelling of a viseme name (image and flow file names).

    Examples
    --------
    >>> viseme_slug("#"), viseme_slug("w-au"), viseme_slug("@"), viseme_slug("ii")
    ('_23', 'w-au', '_40', 'ii')
    """
    if not isinstance(name, str) or not name:
        raise MiketalkError(f"a viseme name must be a non-empty string, got {name!r}")
    out = []
    for i, char in enumerate(name):
        if char in _SAFE or (char == "-" and i > 0):
            out.append(char)
        else:
            out.extend(f"_{byte:02x}" for byte in char.encode("utf-8"))
    return "".join(out)


@dataclass(frozen=True)
class CorpusTarget:
    """One target nucleus of the recorded corpus.

    Attributes
    ----------
    key : str
        ``"ii"``, ``"b"``, ``"ou:1"``, ``"#"``...
    label : str
        The paper's phonemic label (``"ou"`` for both nuclei of \\ou\\).
    klass : str
        ``consonant``, ``monophthong``, ``diphthong`` or ``silence``.
    word : str
        The corpus word (``"-"`` for silence).
    phones : tuple of str
        Festival's pronunciation of the word, pauses dropped.
    position : int
        Index into ``phones`` of the phone that carries the target.
    nucleus : int
        0 for a single-nucleus target, 1 or 2 for a diphthong's nuclei.
    viseme : str
        The viseme this target is grouped into.
    """

    key: str
    label: str
    klass: str
    word: str
    phones: tuple[str, ...]
    position: int
    nucleus: int
    viseme: str

    @property
    def phone(self) -> str:
        """The radio phone that carries the target."""
        return self.phones[self.position]


def read_table(path: Path | str | None, default: str) -> list[dict[str, str]]:
    """Rows of a package data table (``data/<default>``) or of the table at ``path``.

    Comments are ``# ...`` lines (the silence row itself starts with ``#<TAB>``).
    """
    if path is None:
        text = resources.files("miketalk.data").joinpath(default).read_text("utf-8")
        source = f"miketalk/data/{default}"
    else:
        try:
            text = Path(path).read_text("utf-8")
        except OSError as err:
            raise MiketalkError(f"cannot read table {path}: {err.strerror}") from err
        source = str(path)
    # comments are "# ..." lines; the silence row itself starts with "#\t"
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("# ")]
    rows = list(csv.DictReader(lines, delimiter="\t"))
    if not rows:
        raise MiketalkError(f"table {source} has no rows")
    return rows


class VisemeTable:
    """Festival phones -> paper labels -> visemes, with the corpus beside them.

    Parameters
    ----------
    phones_tsv, corpus_tsv : path, optional
        Replacement tables; the packaged ones by default.
    grouping : mapping, optional
        Overrides of the corpus table's ``viseme`` column, ``{key: viseme}``
        (for example ``{"th": "f"}``): the "configured grouping" of 52 targets
        into visemes.

    Raises
    ------
    MiketalkError
        If the tables disagree (a label with no corpus target, a grouping key
        that is not a target).
    """

    def __init__(
        self,
        phones_tsv: Path | None = None,
        corpus_tsv: Path | None = None,
        grouping: Mapping[str, str] | None = None,
    ) -> None:
        grouping = dict(grouping or {})
        targets = []
        for row in read_table(corpus_tsv, "corpus.tsv"):
            key = row["key"]
            nucleus = int(key.rsplit(":", 1)[1]) if ":" in key else 0
            phones = tuple(row["phones"].split())
            position = int(row["position"])
            if not 0 <= position < len(phones):
                raise MiketalkError(f"corpus target {key}: position {position} outside {phones}")
            targets.append(
                CorpusTarget(
                    key=key,
                    label=row["label"],
                    klass=row["class"],
                    word=row["word"],
                    phones=phones,
                    position=position,
                    nucleus=nucleus,
                    viseme=grouping.pop(key, row["viseme"]),
                )
            )
        if grouping:
            raise MiketalkError(f"viseme grouping names unknown corpus targets: {sorted(grouping)}")
        self.targets: tuple[CorpusTarget, ...] = tuple(targets)
        self._by_label: dict[str, list[CorpusTarget]] = {}
        for t in self.targets:
            self._by_label.setdefault(t.label, []).append(t)
        self._label_of: dict[str, str] = {}
        for row in read_table(phones_tsv, "phones.tsv"):
            if row["label"] not in self._by_label:
                raise MiketalkError(
                    f"phone {row['phone']!r} maps to label {row['label']!r}, "
                    "which has no corpus target"
                )
            self._label_of[row["phone"]] = row["label"]
        self.visemes: tuple[str, ...] = tuple(
            dict.fromkeys(
                [v for v in VISEMES if any(t.viseme == v for t in self.targets)]
                + [t.viseme for t in self.targets]
            )
        )

    @property
    def phones(self) -> tuple[str, ...]:
        """Every Festival phone the table knows."""
        return tuple(self._label_of)

    def label_of(self, phone: str) -> str:
        """The paper's label for a Festival phone.

        Raises
        ------
        MiketalkError
            For a phone the table does not know.
        """
        try:
            return self._label_of[phone]
        except KeyError:
            raise MiketalkError(
                f"unknown phone {phone!r}: not in the phone table "
                f"(known: {' '.join(sorted(self._label_of))})"
            ) from None

    def targets_of(self, phone: str) -> tuple[CorpusTarget, ...]:
        """The corpus targets of a phone's label: one, or two for a diphthong."""
        return tuple(self._by_label[self.label_of(phone)])

    def visemes_of(self, phone: str) -> tuple[str, ...]:
        """The viseme(s) of a Festival phone: one, or two (first and second nucleus)."""
        return tuple(t.viseme for t in self.targets_of(phone))

    def spoken_visemes(self, phones: Iterable[str]) -> set[str]:
        """The viseme classes ``phones`` show, silence left out; a phone the table does not
        know (a recognizer's noise label) shows none."""
        classes: set[str] = set()
        for phone in set(phones):
            try:
                classes |= set(self.visemes_of(phone))
            except (KeyError, MiketalkError):
                continue
        classes.discard(SILENCE)
        return classes

    def word_of(self, phone: str) -> str:
        """The corpus word that instantiates a phone's label (``"-"`` for silence)."""
        return self.targets_of(phone)[0].word

    def corpus_words(self) -> list[str]:
        """The corpus words in recording order, each once (silence excluded)."""
        return list(dict.fromkeys(t.word for t in self.targets if t.klass != "silence"))

    def representative(self, viseme: str) -> CorpusTarget:
        """The corpus target whose image stands for ``viseme``.

        The paper kept one image per group. We take the target whose key is the
        viseme's own name (``p`` for {p, b, m}), else the first grouped into it
        in table order (``au:2`` for \\w-au\\).
        """
        members = [t for t in self.targets if t.viseme == viseme]
        for t in members:
            if t.key == viseme:
                return t
        if members:
            return members[0]
        raise MiketalkError(f"unknown viseme {viseme!r}; known: {' '.join(self.visemes)}")


@cache
def default_table() -> VisemeTable:
    """The packaged tables with their own grouping (cached)."""
    return VisemeTable()
