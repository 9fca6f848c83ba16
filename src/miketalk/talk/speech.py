"""What is spoken: typed text, or a :class:`Recorded` recording and what it says (standard
library only: the command line names it before Festival starts and numpy loads)."""

from __future__ import annotations

import os
from dataclasses import dataclass

__all__ = ["PHONES", "Recorded", "Speech"]

#: Where a recording's phones come from (``--phones``): ``aligned`` (its text, when given,
#: aligned to its sound; its recognized words when not) or ``recognized`` (its recognized
#: words, aligned, even when a text is given: the text is then compared with them,
#: :mod:`miketalk.speech.recognize.agree`).
PHONES = ("aligned", "recognized")


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
    phones : str
        Where its phones come from (:data:`PHONES`).

    Raises
    ------
    SettingError
        ``phones`` not one of :data:`PHONES`, or ``recognized`` with ``timings`` (which place
        the given words).
    """

    audio: str | os.PathLike[str]
    text: str | None = None
    timings: str | os.PathLike[str] | None = None
    phones: str = "aligned"

    def __post_init__(self) -> None:
        from miketalk.errors import SettingError

        if self.phones not in PHONES:
            raise SettingError(f"{{phones}} must be {' or '.join(PHONES)}, not {self.phones!r}")
        if self.phones == "recognized" and self.timings is not None:
            raise SettingError(
                "{phones} recognized takes the recording's words from the recognizer; "
                "{timings} place given words: give one of them"
            )


#: What ``say`` and ``dub`` speak: typed text (Festival's voice) or a recording.
Speech = str | Recorded
