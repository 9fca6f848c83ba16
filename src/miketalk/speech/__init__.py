"""Speech: text to audio and timed phones (Festival behind a small back-end interface)."""

from miketalk.speech.backend import PendingSpeech, SpeechBackend, get_backend
from miketalk.speech.festival import FestivalBackend
from miketalk.speech.text import normalize_text, split_chunks
from miketalk.speech.types import Phone, Utterance

__all__ = [
    "FestivalBackend",
    "PendingSpeech",
    "Phone",
    "SpeechBackend",
    "Utterance",
    "get_backend",
    "normalize_text",
    "split_chunks",
]
