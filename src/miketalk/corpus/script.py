"""What is said in a video: its plain transcript or its subtitles, as cues of words.

A plain transcript (any text file) is one cue without times: the long-form
aligner (:mod:`miketalk.speech.long_align`) finds where its words are. Subtitles
are cues with times: SubRip (``.srt``, read with the ``srt`` library) or WebVTT
(``.vtt``, read with ``webvtt-py``). Cue text loses its markup (``<i>``, ``{\\an8}``),
speaker labels (``JOHN:``, ``- ``) and sound descriptions (``[music]``,
``(laughs)``); what is left is normalised as :func:`miketalk.speech.text.normalize_text`
does and split into lower-case words (letters, digits, apostrophes).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from miketalk.errors import MiketalkError

#: Words, once the text is normalised.
_WORD = re.compile(r"[a-z0-9]+(?:'[a-z0-9]+)*")
#: What subtitles carry besides speech.
_MARKUP = re.compile(r"<[^>]*>|\{[^}]*\}")
_SOUNDS = re.compile(r"\[[^\]]*\]|\([^)]*\)|♪[^♪]*♪?")
_SPEAKER = re.compile(r"^\s*(?:-\s*)?(?:[A-Z][A-Z .'-]*:)?\s*", re.MULTILINE)


@dataclass(frozen=True)
class Cue:
    """Words said, and where (seconds) when the source says so.

    Attributes
    ----------
    words : tuple of str
        Lower-case words, in order.
    start, end : float or None
        The cue's span in the video; None for a plain transcript.
    """

    words: tuple[str, ...]
    start: float | None = None
    end: float | None = None


def text_words(text: str) -> list[str]:
    """The lower-case words of ``text`` (normalised to ASCII first; empty when none)."""
    from miketalk.speech.text import normalize_text

    try:
        clean = normalize_text(text)
    except MiketalkError:
        return []
    return _WORD.findall(clean.lower().replace("-", " "))


def read_script(
    *, transcript: str | Path | None = None, subtitles: str | Path | None = None
) -> list[Cue]:
    """The cues of a transcript or of subtitles (exactly one of them).

    Both are read as ``say --file`` reads its text (:func:`script_text`).

    Raises
    ------
    MiketalkError
        Both or neither given, a missing or unreadable file, one too large, a device
        (``/dev/zero``), a file that is not UTF-8 text, subtitles of another format than
        ``.srt`` / ``.vtt``, a cue ending before it starts, cues out of order, or no word
        at all.
    """
    if (transcript is None) == (subtitles is None):
        raise MiketalkError("give the video's transcript or its subtitles (one of them)")
    path = Path(transcript if transcript is not None else subtitles)
    if transcript is not None:
        cues = [Cue(tuple(text_words(script_text(path, "transcript"))))]
    else:
        cues = _read_subtitles(path)
    if not any(c.words for c in cues):
        raise MiketalkError(f"{path} has no words")
    return [c for c in cues if c.words]


def script_text(path: str | Path, what: str = "transcript") -> str:
    """The text of a transcript or subtitles file, read as ``say --file`` reads its text
    (:func:`miketalk.speech.text.read_text_file`: at most 1 MiB, UTF-8, no NUL byte, a
    device that never ends refused unread), a byte-order mark left out.

    Raises
    ------
    MiketalkError
        In one line: ``what`` not found, or the file refused.
    """
    from miketalk.speech.text import read_text_file

    path = Path(path)
    if not path.exists():
        raise MiketalkError(f"{what} not found: {path}")
    return read_text_file(path).removeprefix("\ufeff")


def _read_subtitles(path: Path) -> list[Cue]:
    suffix = path.suffix.lower()
    if suffix not in (".srt", ".vtt"):
        raise MiketalkError(f"subtitles must be .srt or .vtt, not {path.name}")
    text = script_text(path, "subtitles")
    try:
        if suffix == ".srt":
            import srt

            raw = [
                (s.start.total_seconds(), s.end.total_seconds(), s.content) for s in srt.parse(text)
            ]
        else:
            import io

            import webvtt

            raw = [
                (c.start_time.in_milliseconds() / 1000, c.end_time.in_milliseconds() / 1000, c.text)
                for c in webvtt.read_buffer(io.StringIO(text))
            ]
    except MiketalkError:
        raise
    except Exception as err:  # the libraries' own parse errors
        raise MiketalkError(f"cannot read the subtitles {path}: {err}") from err
    cues = []
    previous = 0.0
    for number, (start, end, text) in enumerate(raw, 1):
        if end <= start:
            raise MiketalkError(f"{path}: cue {number} ends ({end:.3f} s) before it starts")
        if start < previous - 1e-3:
            raise MiketalkError(f"{path}: cue {number} starts before the cue before it ends")
        previous = end
        words = text_words(_SPEAKER.sub("", _SOUNDS.sub(" ", _MARKUP.sub("", text))))
        cues.append(Cue(tuple(words), float(start), float(end)))
    return cues
