"""A video's script when it comes without one: its words recognized, the unsure ones left out.

``miketalk build VIDEO`` with no transcript and no subtitles hears the video's sound
(:mod:`miketalk.speech.recognize`) and makes subtitle-like cues of the runs of words heard
with confidence (at least :data:`WORD_CONFIDENCE`), timed as the recognizer heard them. A
word heard with less is left out, its sound with it, and named, as a transcript's words the
aligner cannot place are; the cues are then aligned as subtitles are
(:func:`miketalk.speech.long_align.align_long`), so the phones are the project's own forced
alignment of the words recognized.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

from miketalk.corpus.script import Cue
from miketalk.errors import MiketalkError

if TYPE_CHECKING:
    import numpy as np

    from miketalk.speech.recognize import HeardWord

log = logging.getLogger(__name__)

#: A word heard with less confidence than this is left out of a build (measured: docs/recognize.md).
WORD_CONFIDENCE = 0.5


@dataclass(frozen=True)
class HeardScript:
    """The cues of a video's recognized words and what was left out.

    Attributes
    ----------
    cues : list of Cue
        Runs of words heard with confidence, timed.
    left_out : tuple of HeardWord
        The words heard with less than :data:`WORD_CONFIDENCE`.
    recognizer : str
        Which recognizer and weights heard them.
    """

    cues: list[Cue]
    left_out: tuple[HeardWord, ...]
    recognizer: str

    def record(self) -> dict:
        """What ``segments.json`` (kept in the model's ``build/``) says of where its words came
        from."""
        return {
            "words_from": self.recognizer,
            "not_confident": [
                {"word": w.text, "start": round(w.start, 3), "end": round(w.end, 3),
                 "probability": round(w.probability, 3)}
                for w in self.left_out
            ],
        }  # fmt: skip


def heard_script(samples: np.ndarray, rate: int, source: str) -> HeardScript:
    """The cues of the words a recording is heard to say with confidence.

    Raises
    ------
    MiketalkError
        The recognizer not installed; speech not English, or noise
        (:func:`miketalk.speech.recognize.judge.judge`); no word heard with confidence.
    """
    from miketalk.speech.recognize import get_recognizer, spoken_words
    from miketalk.speech.recognize.judge import DEFAULT_RECOGNIZER, judge

    heard = get_recognizer(DEFAULT_RECOGNIZER).hear(samples, rate)
    judge(heard, source)
    cues: list[Cue] = []
    run: list[HeardWord] = []
    left_out: list[HeardWord] = []

    def close() -> None:
        words = tuple(w for heard_word in run for w in spoken_words(heard_word.text))
        if words:
            cues.append(Cue(words, run[0].start, run[-1].end))
        run.clear()

    for word in heard.words:
        if word.probability >= WORD_CONFIDENCE:
            run.append(word)
        else:
            close()
            left_out.append(word)
    close()
    if not cues:
        raise MiketalkError(
            f"{source}: none of its {len(heard.words)} words was recognized with confidence "
            f"(at least {WORD_CONFIDENCE}); give its --transcript or --subtitles"
        )
    if left_out:
        named = ", ".join(f"{w.text!r} at {w.start:.1f} s" for w in left_out[:8])
        log.warning(
            "%s: %d of the %d words heard are left out, heard without confidence (under %s): "
            "%s%s", source, len(left_out), len(heard.words), WORD_CONFIDENCE, named,
            "..." if len(left_out) > 8 else "",
        )  # fmt: skip
    log.info("%s: built from its recognized words (%s): %s", source, heard.recognizer, heard.text)
    return HeardScript(cues, tuple(left_out), heard.recognizer)
