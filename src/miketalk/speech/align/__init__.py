"""Forced alignment of recorded speech: the timed phones of known words in a recording.

:func:`align_phones` places the phones of a transcript in a recording with
pocketsphinx's aligner (:mod:`~miketalk.speech.align.decoder`), in Festival's
phone set (:mod:`~miketalk.speech.align.pronounce`); :func:`align` also stretches
them onto given word timings (:mod:`~miketalk.speech.align.phones`).
"""

from miketalk.speech.align.decoder import ALIGN_RATE
from miketalk.speech.align.phones import MAX_CLOSURE, SILENCE, Alignment, align, align_phones
from miketalk.speech.align.pronounce import ArpabetTable, arpabet_table, festival_pronunciations

__all__ = [
    "ALIGN_RATE",
    "MAX_CLOSURE",
    "SILENCE",
    "Alignment",
    "ArpabetTable",
    "align",
    "align_phones",
    "arpabet_table",
    "festival_pronunciations",
]
