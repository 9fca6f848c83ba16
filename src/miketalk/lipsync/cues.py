"""Mouth cues for animators (Rhubarb Lip Sync's formats) and timed phones for phoneticians
(a Praat TextGrid).

`Rhubarb Lip Sync <https://github.com/DanielSWolf/rhubarb-lip-sync>`_ describes
speech as a sequence of mouth shapes: the six basic Hanna-Barbera shapes A-F
and the optional G (F, V), H (L) and X (rest). ``data/rhubarb_shapes.tsv`` maps
each of the paper's visemes (and a few phones the viseme grouping does not
separate) to a shape; :func:`mouth_cues` turns timed phones into cues, one per
phone (a diphthong's two halves each get their nucleus's shape), consecutive
equal shapes joined, times rounded to Rhubarb's centiseconds. Shapes outside
the chosen extended set fall back to their basic shape as Rhubarb does (G to
B, H to C, X to A).

Formats, as Rhubarb writes them:

* **JSON** (:func:`rhubarb_json`): ``metadata`` (``soundFile``, ``duration``)
  and ``mouthCues``, a list of ``{"start", "end", "value"}``;
* **TSV** (:func:`rhubarb_tsv`): one ``start<TAB>shape`` line per cue, then
  the end time with the rest shape;
* **TextGrid** (:func:`textgrid`, through praatio): interval tiers ``phones``
  (Festival's radio phones) and ``visemes``, and a point tier ``keyframes``
  (where each viseme is shown in full, what drives the morph).
"""

from __future__ import annotations

import csv
import json
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_paths
from miketalk.media.ownership import Kind, record_path, record_text
from miketalk.media.scratch import scratch_dir
from miketalk.speech.types import Phone
from miketalk.visemes import VisemeTable

if TYPE_CHECKING:  # praatio loads only for a TextGrid
    from praatio.textgrid import Textgrid

#: Rhubarb's shapes: the basic six, then the extended three.
SHAPES = ("A", "B", "C", "D", "E", "F", "G", "H", "X")
#: Rhubarb's ``getBasicShape`` of each extended shape.
BASIC = {"G": "B", "H": "C", "X": "A"}
#: The formats :func:`write_cues` writes, by file suffix.
FORMATS = {".json": "json", ".tsv": "tsv", ".textgrid": "textgrid"}
#: What each format's file is, for :func:`miketalk.media.ownership.check_replaceable`.
CUE_KINDS = {"json": Kind.CUES_JSON, "tsv": Kind.CUES_TSV, "textgrid": Kind.TEXTGRID}

_COMMENT = re.compile(r"#( |$)")
_NUCLEI = {1: (0.0, 1.0), 2: (0.0, 0.5, 1.0)}  # a diphthong's halves, one per nucleus


@dataclass(frozen=True)
class Cue:
    """One mouth shape from ``start`` to ``end`` (seconds)."""

    start: float
    end: float
    value: str


@dataclass(frozen=True)
class ShapeTable:
    """Viseme -> Rhubarb shape, with per-phone exceptions (``data/rhubarb_shapes.tsv``)."""

    by_viseme: dict[str, str]
    by_phone: dict[str, str]

    def shape_of(self, phone: str, viseme: str) -> str:
        """The shape of ``phone`` shown as ``viseme``.

        Raises
        ------
        MiketalkError
            For a viseme the table has no shape for.
        """
        if phone in self.by_phone:
            return self.by_phone[phone]
        try:
            return self.by_viseme[viseme]
        except KeyError:
            raise MiketalkError(f"the Rhubarb shape table has no viseme {viseme!r}") from None


@cache
def default_shapes() -> ShapeTable:
    """The table in ``data/rhubarb_shapes.tsv``."""
    text = resources.files("miketalk").joinpath("data/rhubarb_shapes.tsv").read_text("utf-8")
    return read_shapes(text)


def read_shapes(text: str) -> ShapeTable:
    """Parse a shape table (TSV: key, kind, shape, note; ``# `` starts a comment line, while
    ``#<TAB>`` is the silence viseme's row).

    Raises
    ------
    MiketalkError
        For a row with an unknown kind or shape.
    """
    rows = csv.DictReader(
        (line for line in text.splitlines() if line and not _COMMENT.match(line)), delimiter="\t"
    )
    by_viseme: dict[str, str] = {}
    by_phone: dict[str, str] = {}
    for row in rows:
        if row["shape"] not in SHAPES:
            raise MiketalkError(f"unknown Rhubarb shape {row['shape']!r} for {row['key']!r}")
        if row["kind"] == "viseme":
            by_viseme[row["key"]] = row["shape"]
        elif row["kind"] == "phone":
            by_phone[row["key"]] = row["shape"]
        else:
            raise MiketalkError(f"unknown kind {row['kind']!r} in the shape table")
    return ShapeTable(by_viseme, by_phone)


def check_extended(extended: str) -> str:
    """An extended shape set: any of ``G``, ``H``, ``X`` (as Rhubarb's ``--extendedShapes``)."""
    letters = extended.upper()
    if any(c not in BASIC for c in letters):
        raise MiketalkError(f"extended shapes are letters of GHX, not {extended!r}")
    return "".join(c for c in "GHX" if c in letters)


def _target(shape: str, extended: str) -> str:
    return shape if shape not in BASIC or shape in extended else BASIC[shape]


def phone_parts(
    phones: Sequence[Phone], table: VisemeTable
) -> list[tuple[Phone, str, float, float]]:
    """Each phone's spans with the viseme shown in them: ``(phone, viseme, start, end)``.

    A phone is one span; a diphthong two halves, one per nucleus.
    """
    parts = []
    for phone in phones:
        visemes = table.visemes_of(phone.name)
        cuts = _NUCLEI[len(visemes)]
        for viseme, a, b in zip(visemes, cuts, cuts[1:], strict=False):
            parts.append(
                (phone, viseme, phone.start + a * phone.duration, phone.start + b * phone.duration)
            )
    return parts


def mouth_cues(
    phones: Sequence[Phone],
    table: VisemeTable,
    *,
    duration: float,
    shapes: ShapeTable | None = None,
    extended: str = "GHX",
) -> list[Cue]:
    """Rhubarb mouth cues covering ``[0, duration]``, at centiseconds (see the module docstring).

    Parameters
    ----------
    phones : sequence of Phone
        Timed phones from 0 (Festival's, or a recording's forced alignment).
    table : VisemeTable
        Phone -> viseme.
    duration : float
        Seconds of sound; the cues end there.
    shapes : ShapeTable, optional
        Viseme -> shape (default: ``data/rhubarb_shapes.tsv``).
    extended : str
        Which of Rhubarb's extended shapes G, H, X to use.
    """
    shapes = shapes or default_shapes()
    extended = check_extended(extended)
    end = _cs(duration)
    cues: list[Cue] = []
    for phone, viseme, start, _ in phone_parts(phones, table):
        value = _target(shapes.shape_of(phone.name, viseme), extended)
        at = min(_cs(start), end)
        if cues and cues[-1].value == value:
            continue
        if cues and at <= cues[-1].start:  # shorter than a centisecond: the later shape wins
            cues.pop()
            if cues and cues[-1].value == value:
                continue
        cues.append(Cue(at, at, value))
    if not cues or cues[0].start > 0:
        cues.insert(0, Cue(0.0, 0.0, _target("X", extended)))
    ends = [c.start for c in cues[1:]] + [end]
    closed = [Cue(c.start, e, c.value) for c, e in zip(cues, ends, strict=True)]
    return [c for c in closed if c.end > c.start] or [Cue(0.0, end, _target("X", extended))]


def _cs(seconds: float) -> float:
    """Seconds rounded to centiseconds (Rhubarb's resolution)."""
    return round(seconds * 100) / 100


def rhubarb_json(cues: Sequence[Cue], *, sound_file: str, duration: float) -> str:
    """Rhubarb's JSON export of ``cues`` (its layout, two decimals, as ``rhubarb -f json``)."""
    lines = [
        "{",
        '  "metadata": {',
        f'    "soundFile": {json.dumps(sound_file)},',
        f'    "duration": {_cs(duration):.2f}',
        "  },",
        '  "mouthCues": [',
        ",\n".join(
            f'    {{ "start": {c.start:.2f}, "end": {c.end:.2f}, "value": "{c.value}" }}'
            for c in cues
        ),
        "  ]",
        "}",
    ]
    return "\n".join(lines) + "\n"


def rhubarb_tsv(cues: Sequence[Cue], *, duration: float, extended: str = "GHX") -> str:
    """Rhubarb's TSV export: ``start<TAB>shape`` per cue, then the end with the rest shape."""
    rows = [f"{c.start:.2f}\t{c.value}" for c in cues]
    rows.append(f"{_cs(duration):.2f}\t{_target('X', check_extended(extended))}")
    return "\n".join(rows) + "\n"


def textgrid(phones: Sequence[Phone], table: VisemeTable, *, duration: float) -> Textgrid:
    """A praatio ``Textgrid``: tiers ``phones``, ``visemes`` and ``keyframes``.

    Times are the phones' own (microseconds), not rounded.
    """
    from praatio import textgrid as tg
    from praatio.utilities.constants import Interval, Point

    from miketalk.lipsync.timeline import keyframes

    end = max(duration, phones[-1].end if phones else 0.0)
    grid = tg.Textgrid(0.0, end)
    grid.addTier(
        tg.IntervalTier("phones", [Interval(p.start, p.end, p.name) for p in phones], 0.0, end)
    )
    visemes = [Interval(a, b, v) for _, v, a, b in phone_parts(phones, table) if b > a]
    grid.addTier(tg.IntervalTier("visemes", visemes, 0.0, end))
    keys = [Point(k.time, k.viseme) for k in keyframes(phones, table)]
    grid.addTier(tg.PointTier("keyframes", keys, 0.0, end))
    return grid


def format_of(path: str | os.PathLike[str]) -> str:
    """``json``, ``tsv`` or ``textgrid`` from a file's suffix.

    Raises
    ------
    MiketalkError
        For any other suffix.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise MiketalkError(
            f"cannot tell the format of {Path(path).name!r}: name it .json (Rhubarb JSON), "
            ".tsv (Rhubarb TSV) or .TextGrid (Praat)"
        )
    return FORMATS[suffix]


def render_cues(
    fmt: str,
    phones: Sequence[Phone],
    table: VisemeTable,
    *,
    duration: float,
    sound_file: str = "",
    extended: str = "GHX",
) -> str:
    """The text of one format (``json``, ``tsv`` or ``textgrid``)."""
    if fmt == "textgrid":
        with scratch_dir("textgrid") as tmp:
            path = tmp / "cues.TextGrid"
            textgrid(phones, table, duration=duration).save(
                str(path), format="long_textgrid", includeBlankSpaces=True
            )
            return path.read_text(encoding="utf-8")
    cues = mouth_cues(phones, table, duration=duration, extended=extended)
    if fmt == "json":
        return rhubarb_json(cues, sound_file=sound_file, duration=duration)
    if fmt == "tsv":
        return rhubarb_tsv(cues, duration=duration, extended=extended)
    raise MiketalkError(f"unknown cue format {fmt!r}; known: json, tsv, textgrid")


def write_cues(
    paths: Sequence[str | os.PathLike[str]],
    phones: Sequence[Phone],
    table: VisemeTable,
    *,
    duration: float,
    sound_file: str = "",
    extended: str = "GHX",
    guard: Callable[[], object] | None = None,
) -> list[Path]:
    """Write each of ``paths`` in the format its suffix names.

    Everything is made before anything is written; then the files of each
    directory replace older ones together, or not at all, each with its record beside it
    (:func:`miketalk.media.ownership.record_path`: its size and SHA-256), which tells a
    later run that miketalk wrote it and that it is unchanged since (only then is it
    replaced without ``--force``). ``guard`` runs just before
    they are published, under the output's lock (:func:`~miketalk.media.atomic.atomic_paths`).

    Raises
    ------
    MiketalkError
        An unknown suffix, two paths that are one file, or a directory that
        cannot be written in (before anything is written).
    """
    finals = [Path(p) for p in paths]
    formats = [format_of(p) for p in finals]
    if len({p.resolve() for p in finals}) != len(finals):
        raise MiketalkError("the same output file is named twice")
    for path in finals:
        if path.is_dir():
            raise MiketalkError(f"{path} is a directory: name a file to write")
    texts = [
        render_cues(f, phones, table, duration=duration, sound_file=sound_file, extended=extended)
        for f in formats
    ]
    data = [text.encode("utf-8") for text in texts]
    by_dir: dict[Path, list[int]] = {}
    for i, path in enumerate(finals):
        by_dir.setdefault(path.parent.resolve(), []).append(i)
    for indices in by_dir.values():
        # each file with its record: what tells a later run that miketalk wrote it, as it is
        named = [finals[i] for i in indices]
        with atomic_paths([*named, *map(record_path, named)], guard=guard) as temps:
            for tmp, i in zip(temps, indices, strict=False):
                tmp.write_bytes(data[i])
            for tmp, i in zip(temps[len(indices) :], indices, strict=True):
                tmp.write_text(record_text(finals[i].name, data[i]), encoding="utf-8")
    return finals
