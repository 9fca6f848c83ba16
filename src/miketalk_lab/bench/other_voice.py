"""The training clips spoken again by another voice, at the person's own phone timing.

The ``heard`` trajectory is fitted on the person's recordings. ``say --audio``
and ``dub --audio`` may be given another speaker's (a voice-over): whether what
it learned of his voice holds for another is asked here, with Festival's voices
standing in for the other speaker. Each training clip's words are spoken by
Festival with each phone lasting as long as the person's aligned phone
(:meth:`~miketalk.speech.backend.SpeechBackend.synthesize_retimed`), so that the
other voice's sound lines up with the clip's frames and phones, and the only
difference left is the voice (:mod:`miketalk_lab.bench.trajectory_cv` ``--voice``).
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Sequence
from pathlib import Path

from miketalk.speech.acoustic import Recording
from miketalk.speech.types import Phone
from miketalk.visemes import SILENCE, VisemeTable

#: What a phone the voice speaks and the person did not gets (s): a short moment.
EXTRA_PHONE = 0.02


def retimed_durations(
    names: Sequence[str], phones: Sequence[Phone], table: VisemeTable
) -> list[float]:
    """Durations for the voice's phones ``names`` that follow the person's ``phones``.

    The spoken phones of the two (silences aside) are matched in order
    (:class:`difflib.SequenceMatcher`): a run of as many phones on each side
    (the same, or another pronunciation such as ``ax`` for ``ah``) takes the
    person's durations one by one; a run of a different length shares its
    person's time evenly; a phone only the voice speaks lasts :data:`EXTRA_PHONE`,
    and the time of one only the person spoke goes to the voice's phone before it.
    The voice's first and last silences last as long as the person's lead-in and
    tail; a silence inside the sentence lasts :data:`EXTRA_PHONE`.
    """

    def silent(name: str) -> bool:
        return SILENCE in table.visemes_of(name)

    voice = [i for i, n in enumerate(names) if not silent(n)]
    person = [p for p in phones if not silent(p.name)]
    durations = [EXTRA_PHONE] * len(names)
    if not voice or not person:
        return durations
    matcher = difflib.SequenceMatcher(
        None, [names[i] for i in voice], [p.name for p in person], autojunk=False
    )
    for _, i1, i2, j1, j2 in matcher.get_opcodes():
        spans = [p.duration for p in person[j1:j2]]
        if i2 - i1 == j2 - j1:
            for k, d in enumerate(spans):
                durations[voice[i1 + k]] = d
        elif i2 > i1:
            share = sum(spans) / (i2 - i1) if spans else EXTRA_PHONE
            for i in range(i1, i2):
                durations[voice[i]] = share
        elif i1 > 0:
            durations[voice[i1 - 1]] += sum(spans)
    if voice[0] > 0:
        durations[0] = max(person[0].start - phones[0].start, EXTRA_PHONE)
    if voice[-1] < len(names) - 1:
        durations[-1] = max(phones[-1].end - person[-1].end, EXTRA_PHONE)
    return durations


def clip_words(corpus_dir: str | Path) -> dict[str, str]:
    """Each clip's words (``words.json`` of a corpus folder) as one line of text."""
    doc = json.loads((Path(corpus_dir) / "words.json").read_text(encoding="utf-8"))
    words: dict[str, list[str]] = {}
    for w in doc["words"]:
        words.setdefault(str(w["clip"]), []).append(str(w["word"]))
    return {clip: " ".join(ws) for clip, ws in words.items()}


def voiced_recordings(
    corpus_dir: str | Path,
    clip_ids: Sequence[str],
    phones: Sequence[Sequence[Phone]],
    *,
    voice: str,
    table: VisemeTable,
) -> list[Recording]:
    """Each clip's words spoken by Festival's ``voice`` at the clip's own phone timing
    (:func:`retimed_durations`; the phones in clip time, as ``training_set`` has them)."""
    from miketalk.speech.backend import get_backend

    backend = get_backend("festival", voice=voice)
    texts = clip_words(corpus_dir)
    out = []
    for clip, own in zip(clip_ids, phones, strict=True):
        spoken = backend.synthesize_retimed(
            texts[clip], lambda said, own=own: retimed_durations([p.name for p in said], own, table)
        )
        out.append(Recording(spoken.samples, spoken.rate))
    return out


__all__ = ["EXTRA_PHONE", "clip_words", "retimed_durations", "voiced_recordings"]
