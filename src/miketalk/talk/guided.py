"""A recording's approximate text as a guide: words not said are left out, speech the text
does not hold is filled from the recognizer's words.

:func:`miketalk.talk.recorded.align_recording` aligns a text given alone (no word timings)
as it always did; only when the aligner cannot place one of its words, or the words leave a
stretch of the recording's speech of :data:`UNCOVERED_SECONDS` or more uncovered, is the
text taken as a guide (:func:`guided_alignment`): merged with what the recognizer heard
(:func:`miketalk.speech.align_guide.merge`), aligned again (the words the aligner still
cannot place left out by the long recordings' aligner), and named in one warning. Without
the recognizer installed, the text alone is aligned that way (nothing is filled). Refused
only when under :data:`MIN_TEXT_SHARE` of the text's words are placed.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError

if TYPE_CHECKING:
    import numpy as np

    from miketalk.speech.coverage import SpeechCoverage
    from miketalk.speech.types import Phone

log = logging.getLogger(__name__)

#: A text alone whose aligned words leave a run of voiced sound this long (s) outside them
#: (:attr:`~miketalk.speech.coverage.SpeechCoverage.longest_unexplained`) is a guide.
UNCOVERED_SECONDS = 0.15

#: Under this share of a text's words placed in its recording, the text is refused.
MIN_TEXT_SHARE = 0.3


@dataclass(frozen=True)
class GuidedPhones:
    """What :func:`guided_alignment` placed.

    Attributes
    ----------
    words : tuple of str
        The words placed, in order (the text's kept and the recognizer's filled).
    phones : tuple of Phone
        Their phones, covering the recording.
    score : float or None
        Their fit (:attr:`miketalk.speech.align.phones.Alignment.score_per_frame`; None:
        not measured).
    left_out : tuple of str
        The text's words not placed.
    filled_by : str or None
        The recognizer whose words were filled in (None: none were).
    coverage : SpeechCoverage or None
        When the text's own alignment was kept (nothing heard to change it): how much of
        the speech it explains, for :func:`miketalk.talk.recorded.warn_unexplained`.
    """

    words: tuple[str, ...]
    phones: tuple[Phone, ...]
    score: float | None
    left_out: tuple[str, ...] = ()
    filled_by: str | None = None
    coverage: SpeechCoverage | None = None


def guided_alignment(
    audio: object,
    samples: np.ndarray,
    rate: int,
    text: Sequence[str],
    *,
    unplaced: MiketalkError | None = None,
    phones: tuple[Sequence[Phone], float | None, SpeechCoverage] | None = None,
) -> GuidedPhones:
    """The phones of a recording from its text taken as a guide (the module docstring).

    Parameters
    ----------
    audio : object
        The recording's name (for messages).
    samples : numpy.ndarray
        Its sound, mono int16.
    rate : int
        Its sample rate (the aligner's, 16000).
    text : sequence of str
        The text's words.
    unplaced : MiketalkError, optional
        Why the text could not be aligned whole (a word the aligner cannot place).
    phones : (phones, score, coverage), optional
        The text's own alignment, when it was placed whole but leaves speech uncovered: kept
        when the recognizer hears nothing to fill it with.

    Raises
    ------
    MiketalkError
        Under :data:`MIN_TEXT_SHARE` of the text placed.
    """
    from miketalk.speech.align_guide import Guided, heard_spans, merge
    from miketalk.workers import run_in_child

    why = "no word heard"
    try:  # here, not in a forked child: CTranslate2's threads do not survive a fork
        spans, recognizer = heard_spans(samples, rate)
    except MiketalkError as err:  # not installed: the text alone, nothing filled
        spans, recognizer, why = [], None, str(err)
    guided = merge(text, spans, len(samples) / rate) if spans else Guided.whole(text)
    if phones is not None and not guided.filled and not guided.left_out:
        placed, score, coverage = phones  # nothing heard to change: the text's own alignment
        if not spans:  # the recognizer did not run: say what it could not fill
            log.warning(
                "%s: %.2f s of its speech lie outside the text's words, not filled (%s): does "
                "the text say all that the recording says?",
                audio, coverage.longest_unexplained, why,
            )  # fmt: skip
        return GuidedPhones(tuple(text), tuple(placed), score, coverage=coverage)
    placed, kept, score = (
        run_in_child(place_guided, samples, rate, list(guided.words)) if guided.words
        else ((), [], None)
    )  # fmt: skip
    words = [guided.words[k] for k in kept]
    indices = [guided.text_index[k] for k in kept]
    on_text = sorted(i for i in indices if i is not None)
    if len(on_text) < MIN_TEXT_SHARE * len(text):
        raise MiketalkError(
            f"{audio}: only {len(on_text)} of the text's {len(text)} words could be placed in "
            f"the recording (under {MIN_TEXT_SHARE:.0%}): is the text this recording's?"
        )
    left = [text[i] for i in sorted(set(range(len(text))) - set(on_text))]
    filled = [w for w, i in zip(words, indices, strict=True) if i is None]
    log.warning(
        "%s: the text is a guide here: %d of its %d words placed%s%s",
        audio, len(on_text), len(text),
        f"; left out, not found in the recording: {_quote(left)}" if left else "",
        f"; speech it does not hold filled with the words {recognizer} heard: {_quote(filled)}"
        if filled else "" if spans else f"; speech it does not hold not filled ({why})",
    )  # fmt: skip
    return GuidedPhones(
        tuple(words), tuple(placed), score, tuple(left), recognizer if filled else None
    )


def place_guided(
    samples: np.ndarray, rate: int, words: list[str]
) -> tuple[tuple[Phone, ...], list[int], float | None]:
    """The phones of ``words`` in the recording, which of them were placed (indices) and
    their fit (None: not measured): aligned whole, or when a word cannot be placed, by the
    long recordings' aligner, which leaves such words out."""
    from miketalk.corpus.script import Cue
    from miketalk.speech.align.phones import UnplacedWord, align
    from miketalk.speech.long_align import align_long

    try:
        alignment = align(samples, rate, words)
    except UnplacedWord:
        found = align_long(samples, rate, [Cue(tuple(words), start=None, end=None)])
        return found.phones, [i for i, _ in found.words], None
    return alignment.phones, list(range(len(words))), alignment.score_per_frame


def _quote(words: Sequence[str]) -> str:
    said = " ".join(words)
    return f"'{said if len(said) <= 60 else said[:57] + '...'}' ({len(words)} words)"
