"""A recognizer's written words as the words to align: ``"K2,"`` -> ``k two``.

A recognizer writes what it hears as text (numbers in digits, letters run into digits,
hyphens); the aligner pronounces words of letters. Numbers become their English words
(``2009`` -> ``two thousand nine``, ``3.5`` -> ``three point five``, ``1st`` -> ``first``),
``%`` -> ``percent``, ``$5`` -> ``five dollars``.
"""

from __future__ import annotations

import re

_ONES = (
    "zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen "
    "fifteen sixteen seventeen eighteen nineteen"
).split()
_TENS = "_ _ twenty thirty forty fifty sixty seventy eighty ninety".split()
_SCALES = ((10**9, "billion"), (10**6, "million"), (1000, "thousand"), (100, "hundred"))
_ORDINAL = {
    "one": "first", "two": "second", "three": "third", "five": "fifth", "eight": "eighth",
    "nine": "ninth", "twelve": "twelfth",
}  # fmt: skip
_TOKEN = re.compile(r"\$?\d[\d,]*(?:\.\d+)?(?:st|nd|rd|th|s)?%?|[a-z]+(?:'[a-z]+)*")


def number_words(n: int) -> list[str]:
    """The English words of a whole number under a trillion (``42`` -> ``forty two``)."""
    if n < 20:
        return [_ONES[n]]
    if n < 100:
        return [_TENS[n // 10]] + ([_ONES[n % 10]] if n % 10 else [])
    for scale, name in _SCALES:
        if n >= scale:
            rest = n % scale
            return number_words(n // scale) + [name] + (number_words(rest) if rest else [])
    raise AssertionError(n)  # unreachable: n >= 100 meets the hundred


def _ordinal(words: list[str]) -> list[str]:
    last = words[-1]
    if last in _ORDINAL:
        return [*words[:-1], _ORDINAL[last]]
    return [*words[:-1], (last[:-1] + "ieth") if last.endswith("y") else last + "th"]


def _number(token: str) -> list[str]:
    dollars, token = token.startswith("$"), token.lstrip("$")
    percent, token = token.endswith("%"), token.rstrip("%")
    suffix = re.search(r"(st|nd|rd|th|s)$", token)
    digits = token[: suffix.start()] if suffix else token
    whole, _, fraction = digits.replace(",", "").partition(".")
    if len(whole) > 12:
        words = [_ONES[int(d)] for d in whole]
    else:
        value = int(whole)
        words = number_words(value)
        if len(whole) == 4 and 1100 <= value < 2000 and not dollars:  # a year: "nineteen ..."
            tail = value % 100
            words = number_words(value // 100) + (
                number_words(tail)
                if tail > 9
                else ["hundred"]
                if tail == 0
                else ["oh", _ONES[tail]]
            )
    if suffix and suffix.group() in ("st", "nd", "rd", "th"):
        words = _ordinal(words)
    elif suffix:  # "1990s"
        words[-1] = words[-1][:-1] + "ies" if words[-1].endswith("y") else words[-1] + "s"
    if fraction:
        words += ["point", *(_ONES[int(d)] for d in fraction)]
    return words + (["percent"] if percent else []) + (["dollars"] if dollars else [])


def spoken_words(text: str) -> list[str]:
    """The words to align of a recognizer's text, lower case (letters and apostrophes only).

    Letters run into digits are split (``"F2"`` -> ``f two``), hyphens and other
    punctuation separate words; numbers are spelled (module docstring).
    """
    # "F2" -> "f 2", "2b" -> "2 b"; not "2nd", "1990s"
    spaced = re.sub(r"(?<=[a-z])(?=\d)|(?<=\d)(?!(?:st|nd|rd|th|s)\b)(?=[a-z])", " ", text.lower())
    out: list[str] = []
    for token in _TOKEN.findall(spaced):
        out += _number(token) if token[0] in "$0123456789" else [token]
    return out
