"""Text clean-up before synthesis: transliteration, validation, chunking.

Festival's kal voice crashes (segfaults) on text with nothing to say, reads some
symbols oddly, and slows down on very long utterances; its letter-to-sound
rules take minutes over a word of thousands of letters and crash on longer
ones. Everything that reaches it passes through here first.
"""

from __future__ import annotations

import logging
import os
import re
import stat
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


#: The largest text file read (bytes): 1 MiB, some 170,000 words, more than 15 hours of
#: speech. A larger file, or one that never ends (``/dev/zero``), is refused unread.
MAX_TEXT_BYTES = 1 << 20


def read_text_file(path: str | os.PathLike[str], *, limit: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of ``path``, read in bounded size.

    At most ``limit + 1`` bytes are ever read, so a device or a pipe that never ends
    (``/dev/zero``, ``/dev/urandom``) costs no memory or time.

    Raises
    ------
    MiketalkError
        In one line: a file that cannot be read, larger than ``limit``, holding NUL bytes
        (not text) or not UTF-8.
    """
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if stat.S_ISREG(os.fstat(f.fileno()).st_mode) and size > limit:
                data = None
            else:
                data = f.read(limit + 1)
    except OSError as err:
        raise MiketalkError(f"cannot read {path}: {err.strerror or err}") from None
    if data is None or len(data) > limit:
        what = f"{size} bytes" if data is None else f"more than {limit} bytes"
        raise MiketalkError(
            f"{path} holds {what}: miketalk reads texts of up to {limit} bytes (some "
            f"{limit // 6:,} words); split it"
        )
    if b"\0" in data:
        raise MiketalkError(f"{path} is not a text file (it holds NUL bytes)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise MiketalkError(
            f"{path} is not UTF-8 text (byte {err.start} is not UTF-8): save it as UTF-8"
        ) from None


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
    out = "".join(" " if ord(ch) > 127 else ch for ch in out)
    out = "".join(" " if unicodedata.category(ch) == "Cc" and ch != "\n" else ch for ch in out)
    out = _NOT_SPOKEN.sub(" ", out)
    out = re.sub(r"[ \t]+", " ", out).strip()
    if not _SPEAKABLE.search(out):
        shown = text if len(text) <= 40 else text[:37] + "..."
        scripts = _scripts(dropped)
        if scripts:
            raise MiketalkError(
                f"nothing to speak in {shown!r}: Festival's voices speak English, and the text "
                f"has no English word (its letters are {', '.join(scripts)})"
            )
        raise MiketalkError(f"nothing to speak in {shown!r}: the text has no letters or digits")
    if dropped:
        log.warning("no transliteration for %s: read as spaces", " ".join(dropped))
    check_word_lengths(out)
    return out


def _scripts(characters: list[str]) -> list[str]:
    """The writing systems of the letters among ``characters`` (Greek, CJK, Cyrillic...)."""
    names = []
    for ch in characters:
        if ch.isalpha():
            name = unicodedata.name(ch, "").split(" ")[0]
            script = {"CJK": "Chinese (CJK)"}.get(name, name.capitalize())
            if script and script not in names:
                names.append(script)
    return names


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


#: The most words one text is spoken with (some 60 minutes of speech). The work of each
#: sentence is bounded (:func:`split_sentences`: at most ``max_words`` words, however long
#: the line), and the frames stream (:mod:`miketalk.talk.stream`); what is kept of the whole
#: is its timeline and sound for the JSON and the measures of its motion.
MAX_SPOKEN_WORDS = 10_000


def check_spoken_length(text: str, *, limit: int = MAX_SPOKEN_WORDS) -> None:
    """Refuse a text of more than ``limit`` words, in one line that says the limit.

    Raises
    ------
    MiketalkError
        When ``text`` has more than ``limit`` words (runs of letters or digits).
    """
    words = 0
    for words, _ in enumerate(_WORD.finditer(text), 1):
        if words > limit:
            break
    if words > limit:
        raise MiketalkError(
            f"the text has more than {limit:,} words (some 60 minutes of speech): miketalk "
            f"speaks at most {limit:,} at a time; split it"
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
    chunks: list[str] = []
    current: list[str] = []
    for piece in split_sentences(text, max_words=max_words):
        n = len(piece.split())
        if current and sum(len(c.split()) for c in current) + n > max_words:
            chunks.append(" ".join(current))
            current = []
        current.append(piece)
    if current:
        chunks.append(" ".join(current))
    return chunks


def split_sentences(text: str, *, max_words: int = 40) -> list[str]:
    """Split normalized text into its sentences, each speakable: the pieces
    :func:`split_chunks` packs into chunks, one by one (the face draws a sentence while
    Festival speaks the next).

    Sentences end with ``. ! ? ; :`` or a blank line; one longer than ``max_words`` words
    is cut at commas, then between words. Pieces with nothing speakable (stray
    punctuation) are left out, since Festival crashes on them.
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
    return [p for p in pieces if _SPEAKABLE.search(p)]
