"""Festival as a subprocess: text -> wav + timed radio phones, in one of the voices of
:mod:`miketalk.speech.festival.voices`.

The Scheme program is package data (``scheme/synthesize.scm``); settings reach it
through environment variables, the text through files in its scratch directory (each
chunk one Scheme string datum, read and never evaluated), so user text is never parsed
as Scheme code (Festival's Scheme can run shell commands) and a long text never meets the
environment's or the command line's size limit.

numpy is imported inside the functions that build arrays, not at the top: so
``miketalk say`` can start Festival (:meth:`FestivalBackend.start`) before
numpy has loaded, and the two overlap.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.media.scratch import scratch_dir
from miketalk.speech.backend import Retime, SpeechBackend, register
from miketalk.speech.festival.output import (
    Chunk,
    check_followed,
    check_follows_durations,
    check_same_phones,
    join_chunks,
    read_chunk,
    split_ends,
    write_ends,
)
from miketalk.speech.festival.run import FestivalRun, check_exit
from miketalk.speech.festival.voices import DEFAULT_VOICE, Voice, get_voice, install_hint
from miketalk.speech.text import check_spoken_length, normalize_text, split_chunks
from miketalk.speech.types import Utterance

if TYPE_CHECKING:
    from miketalk.speech.festival.steps import FestivalSteps


@register
class FestivalBackend(SpeechBackend):
    """Festival run as ``festival -b synthesize.scm``.

    Parameters
    ----------
    executable : str, optional
        Path to ``festival``; else ``$MIKETALK_FESTIVAL``; else ``festival`` on PATH.
    voice : str
        A voice of :data:`~miketalk.speech.festival.voices.VOICES` by its short
        name (``kal``, ``ked``, ``slt``) or Festival's function name; all speak
        the radio phone set that the viseme table maps.
    max_words : int
        Text is spoken in chunks of whole sentences of at most this many words
        (Festival slows down and loses time precision on long utterances).
    timeout : float
        Seconds allowed per Festival run.
    heap : int
        Festival's Lisp heap, in cells. Festival's default of 10 million costs
        about 0.25 s of start-up (the kernel zeroing 330 MB); a chunk of
        ``max_words`` words needs far less. Too small a heap is reported as a
        Festival failure.
    """

    name = "festival"

    def __init__(
        self,
        executable: str | None = None,
        *,
        voice: str = DEFAULT_VOICE,
        max_words: int = 40,
        timeout: float = 600.0,
        heap: int = 1_000_000,
    ) -> None:
        self.executable = executable or os.environ.get("MIKETALK_FESTIVAL") or "festival"
        self.voice: Voice = get_voice(voice)
        self.max_words = max_words
        self.timeout = timeout
        if isinstance(heap, bool) or not isinstance(heap, int) or heap < 100_000:
            raise MiketalkError(f"heap must be an integer of at least 100000 cells, got {heap!r}")
        self.heap = heap

    # -- availability -----------------------------------------------------------------
    def _path(self) -> str:
        path = shutil.which(self.executable)
        if path is None:
            raise MiketalkError(
                f"Festival not found ({self.executable!r}); {install_hint(self.voice)}"
            )
        return path

    def is_available(self) -> bool:
        """Whether the executable exists and the voice loads."""
        try:
            self.synthesize("a")
        except MiketalkError:
            return False
        return True

    @cached_property
    def _version(self) -> str:
        out = subprocess.run(
            [self._path(), "--version"], capture_output=True, text=True, timeout=30, check=False
        )
        match = re.search(r"System: ([0-9][^:\s]*)", out.stdout + out.stderr)
        return match.group(1) if match else (out.stdout + out.stderr).strip()

    def version(self) -> str:
        """Festival's version, e.g. ``"2.5.0"``."""
        return self._version

    # -- synthesis ----------------------------------------------------------------------
    def synthesize(self, text: str) -> Utterance:
        """Speak ``text``.

        Raises
        ------
        MiketalkError
            Nothing speakable in ``text``, Festival missing, or Festival failing.
        """
        clean = normalize_text(text)
        check_spoken_length(clean)
        chunks = self._run(split_chunks(clean, max_words=self.max_words), None)
        return join_chunks(clean, chunks)

    def synthesize_each(self, texts: Sequence[str]) -> list[Utterance]:
        """Speak each text as its own utterance, all in one Festival run.

        Faster than calling :meth:`synthesize` per text (Festival starts once);
        each text must fit in one chunk (``max_words``).

        Raises
        ------
        MiketalkError
            As :meth:`synthesize`, naming the offending text.
        """
        clean = [normalize_text(t) for t in texts]
        for text in clean:
            if len(split_chunks(text, max_words=self.max_words)) != 1:
                raise MiketalkError(f"{text[:40]!r}... is too long for synthesize_each")
        return [join_chunks(t, [c]) for t, c in zip(clean, self._run(clean, None), strict=True)]

    def resynthesize(self, utterance: Utterance, durations: Sequence[float]) -> Utterance:
        """Speak ``utterance`` again with dictated phone durations (seconds).

        The text is re-read through the modules up to Duration, each Segment's
        end is set from ``durations``, then Int_Targets and Wave_Synth run.

        Raises
        ------
        MiketalkError
            Wrong number of durations, a non-positive or non-finite duration, a
            voice that sets its own durations, or Festival producing other
            phones than ``utterance`` has.
        """
        check_follows_durations(self.voice)
        texts = split_chunks(utterance.text, max_words=self.max_words)
        sizes = [n for _, n in utterance.chunks] if utterance.chunks else [len(utterance.phones)]
        if len(sizes) != len(texts):
            raise MiketalkError("the utterance's chunks do not match its text; synthesize it again")
        ends = split_ends(durations, sizes)
        chunks = self._run(texts, ends)
        check_same_phones(chunks, [p.name for p in utterance.phones])
        check_followed(chunks, ends)
        return join_chunks(utterance.text, chunks)

    def synthesize_retimed(self, text: str, retime: Retime) -> Utterance:
        """Speak ``text`` with durations ``retime`` may change, in one Festival run.

        Festival predicts the phones and their durations, stops, and hands them
        (as an audio-less :class:`Utterance`) to ``retime``; whatever durations
        it returns are dictated before the wave is made. Equal to
        :meth:`synthesize` then :meth:`resynthesize`, without starting Festival
        and analysing the text twice.

        Raises
        ------
        MiketalkError
            As :meth:`synthesize` and :meth:`resynthesize`.
        """
        with self.start(text) as speech:
            return speech.finish(retime)

    def start(self, text: str) -> FestivalRun:
        """Start Festival on ``text`` now; :meth:`PendingSpeech.finish` dictates the durations.

        Festival starts, loads its voice and predicts the phones while the
        caller goes on; ``finish`` waits for the prediction, hands it to
        ``retime``, and lets Festival make the wave.

        Raises
        ------
        MiketalkError
            Nothing speakable in ``text``, or Festival missing.
        """
        return FestivalRun(self, text)

    def start_sentences(self, text: str) -> FestivalSteps:
        """Start Festival on ``text`` now, to speak it sentence by sentence
        (:class:`~miketalk.speech.festival.steps.FestivalSteps`): the caller draws a
        sentence while Festival speaks the next.

        Raises
        ------
        MiketalkError
            Nothing speakable in ``text``, or Festival missing.
        """
        from miketalk.speech.festival.steps import FestivalSteps

        return FestivalSteps(self, text)

    @contextmanager
    def _workspace(self, texts: list[str]) -> Iterator[tuple[Path, dict[str, str], list[str]]]:
        """A scratch directory holding ``texts``, the environment, and the command line."""
        festival = self._path()
        scheme = resources.files("miketalk.speech").joinpath("scheme/synthesize.scm")
        with scratch_dir("festival") as tmp, resources.as_file(scheme) as scheme_path:
            env = {
                "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
                "HOME": str(tmp),
                "MIKETALK_VOICE": self.voice.function,
                "MIKETALK_OUT": str(tmp),
                "MIKETALK_CHUNKS": str(len(texts)),
            }
            for i, chunk_text in enumerate(texts):  # files: never the environment
                quoted = chunk_text.replace("\\", "\\\\").replace('"', '\\"')
                (tmp / f"{i}.txt").write_text(f'"{quoted}"', encoding="ascii")
            yield tmp, env, [festival, "--heap", str(self.heap), "-b", str(scheme_path)]

    def _run(self, texts: list[str], ends: list[tuple[float, ...]] | None) -> list[Chunk]:
        with self._workspace(texts) as (tmp, env, command):
            if ends is not None:
                for i, chunk_ends in enumerate(ends):
                    path = write_ends(tmp, i, chunk_ends)
                    env[f"MIKETALK_ENDS_{i}"] = str(path)
            try:
                proc = subprocess.run(
                    command,
                    env=env,
                    cwd=tmp,
                    capture_output=True,
                    text=True,
                    timeout=self.timeout,
                    check=False,
                )
            except subprocess.TimeoutExpired:
                raise MiketalkError(f"Festival took longer than {self.timeout:.0f} s") from None
            check_exit(proc.returncode, proc.stderr + proc.stdout, self.voice)
            return [read_chunk(tmp, i, t) for i, t in enumerate(texts)]
