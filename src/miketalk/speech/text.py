"""Text clean-up before synthesis: transliteration, validation, chunking.

Festival's kal voice crashes (segfaults) on text with nothing to say, reads some
symbols oddly, and slows down on very long utterances; its letter-to-sound
rules take minutes over a word of thousands of letters and crash on longer
ones. Everything that reaches it passes through here first.
"""

from __future__ import annotations

import logging
import re
import unicodedata

from miketalk.errors import MiketalkError

log = logging.getLogger(__name__)

# Letters NFKD does not decompose into ASCII, and typographic punctuation.
_TRANSLITERATE = str.maketrans(
    {
        "ß": "ss", "æ": "ae", "Æ": "AE", "ø": "o", "Ø": "O", "œ": "oe", "Œ": "OE",
        "ł": "l", "Ł": "L", "đ": "d", "Đ": "D", "ð": "dh", "Ð": "Dh", "þ": "th", "Þ": "Th",
        "ı": "i", "‘": "'", "’": "'", "‚": ",", "“": " ", "”": " ", "„": " ", "«": " ",
        "»": " ", "–": "-", "—": ", ", "…": "...", "€": " euros ", "£": " pounds ",
        "\u00a0": " ",
    }
)  # fmt: skip

# Characters that Festival's tokenizer treats as quoting or that carry no speech.
_NOT_SPOKEN = re.compile(r'["\\`{}\[\]<>|^~_]')
_SPEAKABLE = re.compile(r"[A-Za-z0-9]")
_SENTENCE_END = re.compile(r"(?<=[.!?;:])\s+|\n\s*\n?")

#: The longest run of letters or digits Festival is given. English words are
#: under 50 letters; Festival reads 400 letters in about a second, takes 254 s
#: over 10,000 and crashes on 10,000 more.
MAX_WORD = 100
_WORD = re.compile(r"[A-Za-z0-9']+")


def normalize_text(text: str) -> str:
    """Return ``text`` as plain ASCII that Festival reads as words.

    Accented letters are transliterated (``café`` -> ``cafe``), typographic
    quotes and dashes become ASCII, control characters and double quotes become
    spaces. A character with no transliteration is replaced by a space and
    logged as a warning, never dropped silently.

    Raises
    ------
    MiketalkError
        If ``text`` is not a string, nothing speakable is left (empty,
        whitespace-only or punctuation-only text), or a word is longer than
        :data:`MAX_WORD` letters or digits.
    """
    if not isinstance(text, str):
        raise MiketalkError(f"text must be a string, not {type(text).__name__}")
    out = unicodedata.normalize("NFKD", text.translate(_TRANSLITERATE))
    out = "".join(ch for ch in out if not unicodedata.combining(ch))
    dropped = sorted({ch for ch in out if ord(ch) > 127})
    if dropped:
        log.warning("no transliteration for %s: read as spaces", " ".join(dropped))
        out = "".join(" " if ord(ch) > 127 else ch for ch in out)
    out = "".join(" " if unicodedata.category(ch) == "Cc" and ch != "\n" else ch for ch in out)
    out = _NOT_SPOKEN.sub(" ", out)
    out = re.sub(r"[ \t]+", " ", out).strip()
    if not _SPEAKABLE.search(out):
        shown = text if len(text) <= 40 else text[:37] + "..."
        raise MiketalkError(f"nothing to speak in {shown!r}: the text has no letters or digits")
    check_word_lengths(out)
    return out


def check_word_lengths(text: str) -> None:
    """Reject a run of letters or digits longer than :data:`MAX_WORD`, naming it.

    Raises
    ------
    MiketalkError
        For the first such word, with its start and its length.
    """
    for match in _WORD.finditer(text):
        word = match.group()
        if len(word) > MAX_WORD:
            raise MiketalkError(
                f"the word {word[:24]}... is {len(word)} letters long; Festival reads "
                f"words of up to {MAX_WORD}: put spaces in it"
            )


def split_chunks(text: str, *, max_words: int = 40) -> list[str]:
    """Split normalized text into chunks of whole sentences, each speakable.

    Sentences (ended by ``. ! ? ; :`` or a blank line) are packed into chunks of
    at most ``max_words`` words; a longer sentence is cut at commas, then
    between words. Chunks with nothing speakable (stray punctuation) are left
    out, since Festival crashes on them.

    Parameters
    ----------
    text : str
        Text already passed through :func:`normalize_text`.
    max_words : int
        The most words in one chunk.
    """
    pieces: list[str] = []
    for sentence in _SENTENCE_END.split(text):
        words = sentence.split()
        if len(words) <= max_words:
            pieces.append(" ".join(words))
            continue
        part: list[str] = []
        for word in words:
            part.append(word)
            if len(part) >= max_words or (word.endswith(",") and len(part) >= max_words // 2):
                pieces.append(" ".join(part))
                part = []
        pieces.append(" ".join(part))
    chunks: list[str] = []
    current: list[str] = []
    for piece in (p for p in pieces if _SPEAKABLE.search(p)):
        n = len(piece.split())
        if current and sum(len(c.split()) for c in current) + n > max_words:
            chunks.append(" ".join(current))
            current = []
        current.append(piece)
    if current:
        chunks.append(" ".join(current))
    return chunks
