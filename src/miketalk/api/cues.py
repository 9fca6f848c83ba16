"""``cues``: the mouth cues of a text or a recording, for animators: Rhubarb Lip Sync's JSON or
TSV, and a Praat TextGrid of the timed phones and visemes (:mod:`miketalk.lipsync.cues`)."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

from miketalk.api.results import CuesResult
from miketalk.api.settings import CuesSettings, check_recorded_speech
from miketalk.errors import MiketalkError, SettingError
from miketalk.speech.festival.voices import DEFAULT_VOICE
from miketalk.talk.speech import Recorded, Speech

__all__ = ["cues", "phones"]

log = logging.getLogger("miketalk")


def cues(
    speech: Speech,
    outputs: Sequence[str | os.PathLike[str]] = (),
    settings: CuesSettings | None = None,
    *,
    wav: str | os.PathLike[str] | None = None,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> CuesResult:
    """Write the mouth cues of ``speech`` to each of ``outputs`` (their format from the suffix:
    ``.json``, ``.tsv``, ``.TextGrid``), and Festival's sound of a text to ``wav``.

    Parameters
    ----------
    speech : str or Recorded
        Typed text (Festival speaks it), or a recording and what it says.
    outputs : sequence of path-like
        The files to write (none: the result renders them, :meth:`CuesResult.render`).
    settings : CuesSettings, optional
        Rhubarb's extended shapes, the voice, whether to replace files miketalk did not write.
    wav : path-like, optional
        With a text: where to save Festival's speech.
    inputs : sequence of path-like
        Files the caller read for this (a text file): never written over.

    Returns
    -------
    CuesResult

    Raises
    ------
    MiketalkError
        In one line, before Festival runs where it can: a format not known, a directory or a
        file miketalk did not write named as an output, a setting for typed text given with
        a recording.
    """
    from miketalk.lipsync.cues import CUE_KINDS, format_of, write_cues
    from miketalk.media.atomic import check_writable
    from miketalk.media.ownership import Kind, check_replaceable
    from miketalk.visemes import default_table

    settings = settings if settings is not None else CuesSettings()
    outputs = [Path(p) for p in outputs]
    for path in outputs:
        format_of(path)
        if path.is_dir():
            raise MiketalkError(f"{path} is a directory: name a file to write")
    recorded = isinstance(speech, Recorded)
    if recorded:
        check_recorded_speech(settings)
        if wav is not None:
            raise SettingError(
                "{wav} saves Festival's speech; with {audio} the recording is the sound"
            )
        inputs = (*inputs, speech.audio, speech.timings)
    if wav is not None and Path(wav).suffix.lower() != ".wav":
        raise SettingError(f"{{wav}} must name a .wav file, not {Path(wav).name!r}")
    kinds = [(p, CUE_KINDS[format_of(p)]) for p in outputs]
    kinds += [(Path(wav), Kind.WAV)] if wav is not None else []
    force = settings.overwrite
    for path, kind in kinds:  # before Festival runs
        option = "--wav" if kind == Kind.WAV else "-o"
        check_replaceable(path, kind, inputs=inputs, force=force, option=option)
        check_writable(path)
    if recorded:
        from miketalk.talk.recorded import align_recording

        aligned = align_recording(
            speech.audio, text=speech.text, timings=speech.timings, phones=speech.phones
        )
        phones, duration = aligned.phones, aligned.duration
        sound_file = str(Path(speech.audio).resolve())
    else:
        from miketalk.speech import get_backend

        utterance = get_backend("festival", voice=settings.voice or DEFAULT_VOICE).synthesize(
            speech
        )
        phones, duration = utterance.phones, utterance.duration
        sound_file = ""
        if wav is not None:
            from miketalk.media.audio import write_wav

            write_wav(
                wav, utterance.samples, utterance.rate, software=True,
                guard=lambda: check_replaceable(
                    wav, Kind.WAV, inputs=inputs, force=force, option="--wav"
                ),
            )  # fmt: skip
            sound_file = str(Path(wav).resolve())
    if outputs:
        write_cues(
            outputs, phones, default_table(), duration=duration, sound_file=sound_file,
            extended=settings.extended_shapes,
            guard=lambda: [
                check_replaceable(p, kind, inputs=inputs, force=force)
                for p, kind in kinds
                if kind != Kind.WAV
            ],
        )  # fmt: skip
        for path in outputs:
            log.info("wrote %s", path)
    return CuesResult(tuple(phones), duration, sound_file, settings.extended_shapes, tuple(outputs))


def phones(text: str, *, voice: str | None = None):
    """The timed phones Festival speaks ``text`` with (``voice``; None: kal), as an
    :class:`~miketalk.speech.types.Utterance` (its sound, rate and phones)."""
    from miketalk.speech import get_backend

    return get_backend("festival", voice=voice or DEFAULT_VOICE).synthesize(text)
