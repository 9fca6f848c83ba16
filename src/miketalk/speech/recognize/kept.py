"""What a recognizer heard in a recording, kept for the next run that hears the same one.

Issue 53's one-command ``dub VIDEO --audio REC`` (no ``--model``, no ``--text``) recognizes
``REC`` at every run: loading Whisper's weights (their sha256 checked) and decoding took
about 2.4 s of the 12.9 s of CPU a second dub of 10 s of 720p took. The recognizer decodes
at temperature 0 (:mod:`~miketalk.speech.recognize.whisper`): the same samples give the same
words. :func:`kept_hear` keeps what it heard in the user's cache
(:mod:`miketalk.media.user_cache`, kind :data:`KIND`, one small JSON record) under a name
made of the samples' SHA-256, shape and type, the rate, the recognizer's name and weights'
checksums, the package's version, the SHA-256 of the recognizer's own source, and the
versions of faster-whisper and CTranslate2. Only a recognizer whose ``hear`` is the
package's own is kept (a stand-in's never is); without a cache everything is heard again.
"""

from __future__ import annotations

import hashlib
import logging
from pathlib import Path
from typing import Any

import numpy as np

from miketalk.speech.recognize.base import Heard, HeardWord, Recognizer

__all__ = ["KIND", "heard_key", "kept_hear"]

log = logging.getLogger(__name__)

#: The kind of cache record (:func:`~miketalk.media.user_cache.read_record`).
KIND = "heard"

#: The record's layout; a change makes every old record another key.
FORMAT = 1


def _versions() -> list[str]:
    """faster-whisper's and CTranslate2's installed versions ("" when not installed)."""
    from importlib.metadata import PackageNotFoundError, version

    found = []
    for name in ("faster-whisper", "ctranslate2"):
        try:
            found.append(version(name))
        except PackageNotFoundError:
            found.append("")
    return found


def heard_key(recognizer: Recognizer, samples: np.ndarray, rate: int) -> list | None:
    """What names what ``recognizer`` hears in ``samples`` (see the module docstring); None
    for a recognizer whose ``hear`` is not the package's own."""
    from miketalk import __version__

    hear = getattr(type(recognizer), "hear", None)
    if not getattr(hear, "__module__", "").startswith("miketalk.speech.recognize."):
        return None
    weights = getattr(recognizer, "weights", None)
    sums = [list(map(str, f[2:])) for f in getattr(weights, "files", ())]
    source = hashlib.sha256()
    for path in sorted(Path(__file__).resolve().parent.glob("*.py")):
        source.update(path.name.encode() + path.read_bytes())
    audio = np.ascontiguousarray(samples)
    return [
        FORMAT, __version__, recognizer.name, sums, source.hexdigest(), _versions(), int(rate),
        str(audio.dtype), list(audio.shape), hashlib.sha256(audio.tobytes()).hexdigest(),
    ]  # fmt: skip


def _record(heard: Heard) -> dict[str, Any]:
    return {
        "words": [[w.text, w.start, w.end, w.probability] for w in heard.words],
        "language": heard.language, "english": heard.english,
        "recognizer": heard.recognizer, "speech_seconds": heard.speech_seconds,
    }  # fmt: skip


def _heard(record: dict[str, Any]) -> Heard:
    words = tuple(HeardWord(str(t), float(s), float(e), float(p)) for t, s, e, p in record["words"])
    return Heard(
        words, str(record["language"]), float(record["english"]), str(record["recognizer"]),
        float(record["speech_seconds"]),
    )  # fmt: skip


def kept_hear(recognizer: Recognizer, samples: np.ndarray, rate: int) -> Heard:
    """``recognizer.hear(samples, rate)``, or what it heard in the same samples before.

    Raises
    ------
    MiketalkError
        What :meth:`~miketalk.speech.recognize.base.Recognizer.hear` raises (never kept).
    """
    from miketalk.media.user_cache import read_record, write_record

    key = heard_key(recognizer, samples, rate)
    if key is not None and (record := read_record(KIND, *key)) is not None:
        try:
            heard = _heard(record)
        except (KeyError, TypeError, ValueError) as err:
            log.debug("the kept record of what was heard was not read (%s): heard again", err)
        else:
            log.info("what %s hears in this recording was kept from a run before", heard.recognizer)
            return heard
    heard = recognizer.hear(samples, rate)
    if key is not None:
        write_record(KIND, _record(heard), *key)
    return heard
