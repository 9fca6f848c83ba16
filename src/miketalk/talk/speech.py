"""What is spoken: typed text, or a :class:`Recorded` recording and what it says (standard
library only: the command line names it before Festival starts and numpy loads)."""

from __future__ import annotations

import os
from dataclasses import dataclass

__all__ = ["Recorded", "Speech"]


@dataclass(frozen=True)
class Recorded:
    """A recording for :func:`miketalk.talk.say.say` to speak, and what it says.

    Attributes
    ----------
    audio : path-like
        The recording (wav, mp4, mpg: anything ffmpeg reads with an audio stream).
    text : str or None
        What is said. Without it and without ``timings``, the words are recognized
        (:mod:`miketalk.speech.recognize`), then aligned as a given text is.
    timings : path-like or None
        Word timings of the recording (``.align`` or ``.TextGrid``); see
        :func:`miketalk.talk.recorded.align_recording`.
    """

    audio: str | os.PathLike[str]
    text: str | None = None
    timings: str | os.PathLike[str] | None = None


#: What ``say`` and ``dub`` speak: typed text (Festival's voice) or a recording.
Speech = str | Recorded
