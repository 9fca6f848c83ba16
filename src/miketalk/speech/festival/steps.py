"""One Festival run speaking a text sentence by sentence (``MIKETALK_STEPS``).

Festival plans sentence ``k`` (its phones and their durations), waits to be told to go
(any dictated durations written first), makes its wave, then plans sentence ``k + 1`` at
once: while the caller draws the face for sentence ``k``, Festival is already on the next.
A text of one sentence is spoken exactly as :class:`~miketalk.speech.festival.run.FestivalRun`
speaks it (the same chunk text, the same Festival calls). The text reaches Festival only
through files in its scratch directory, as in every mode.
"""

from __future__ import annotations

import os
import re
import select
import subprocess
import time
from collections.abc import Iterator
from contextlib import ExitStack, suppress

from miketalk.errors import MiketalkError
from miketalk.speech.backend import PendingSpeech, Retime
from miketalk.speech.festival.output import (
    check_followed,
    check_follows_durations,
    check_same_phones,
    join_chunks,
    read_chunk,
    read_plan,
    split_ends,
    write_ends,
)
from miketalk.speech.festival.run import FestivalSession, check_exit, start_festival
from miketalk.speech.text import check_spoken_length, normalize_text, split_sentences
from miketalk.speech.types import Utterance

__all__ = ["FestivalSteps"]


class FestivalSteps(PendingSpeech):
    """Festival started on a text, speaking it a sentence at a time (:meth:`sentences`).

    ``finish(retime)`` speaks the whole text (every sentence, joined) for a caller that
    wants it at once; :meth:`sentences` gives each sentence as a :class:`PendingSpeech` of
    its own, to be finished in order.
    """

    def __init__(self, backend: FestivalSession, text: str) -> None:
        clean = normalize_text(text)
        check_spoken_length(clean)
        super().__init__(backend, clean)
        self.texts = split_sentences(clean, max_words=backend.max_words)
        self._stack = ExitStack()
        self._proc: subprocess.Popen | None = None
        self._buffer = b""
        self._errors = ""
        self._next = 0
        try:
            self._tmp, self._proc = start_festival(
                self._stack, backend, self.texts, "MIKETALK_STEPS"
            )
        except BaseException:
            self.close()
            raise

    def sentences(self) -> Iterator[PendingSpeech]:
        """Each sentence, to be finished (:meth:`PendingSpeech.finish`) before the next."""
        for index, text in enumerate(self.texts):
            yield _Sentence(self, index, text)

    def finish(self, retime: Retime) -> Utterance:
        """The whole text spoken, sentence after sentence, joined (``retime`` per sentence)."""
        try:
            return _join(self.text, [s.finish(retime) for s in self.sentences()])
        finally:
            self.close()

    def speak(self, index: int, text: str, retime: Retime) -> Utterance:
        """Sentence ``index``: its plan handed to ``retime``, its durations dictated, its
        wave made and read (its files then removed)."""
        proc, tmp, voice = self._proc, self._tmp, self.backend.voice
        if proc is None:
            raise MiketalkError("this Festival run was already finished or closed")
        if index != self._next:
            raise MiketalkError(f"sentence {index} asked for before sentence {self._next}")
        self._next += 1
        deadline = time.monotonic() + self.backend.timeout
        try:
            self._wait_for(f"miketalk: planned {index}\n", deadline)
            planned = read_plan(tmp, index, text, voice.rate)
            durations = retime(join_chunks(text, [planned]).phones)
            ends = None
            if durations is not None:
                check_follows_durations(voice)
                ends = split_ends(durations, [len(planned.names)])
                write_ends(tmp, index, ends[0])
            try:
                proc.stdin.write(b"go\n")
                proc.stdin.flush()
            except BrokenPipeError:  # Festival died after planning: its exit says why
                pass
            self._wait_for(f"miketalk: spoken {index}\n", deadline)
            chunk = read_chunk(tmp, index, text)
            check_same_phones([chunk], list(planned.names))
            if ends is not None:
                check_followed([chunk], ends)
        except subprocess.TimeoutExpired:
            raise MiketalkError(f"Festival took longer than {self.backend.timeout:.0f} s") from None
        except BaseException:
            self.close()
            raise
        for suffix in ("txt", "plan", "wav", "phones", "ends"):
            with suppress(OSError):
                (tmp / f"{index}.{suffix}").unlink()
        return join_chunks(text, [chunk])

    def _wait_for(self, marker: str, deadline: float) -> None:
        """Read Festival's stderr up to the line ``marker``; a Festival that ended first is
        reported with its own words."""
        proc = self._proc
        fd = proc.stderr.fileno()
        wanted = marker.encode()
        while wanted not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise MiketalkError(f"Festival took longer than {self.backend.timeout:.0f} s")
            ready, _, _ = select.select([fd], [], [], left)
            if not ready:
                continue
            block = os.read(fd, 65536)
            if not block:  # Festival exited
                proc.wait(timeout=max(deadline - time.monotonic(), 0.1))
                stdout = (self._tmp / "stdout").read_text(errors="replace")
                text = self._buffer.decode(errors="replace")
                check_exit(proc.returncode or 1, text + stdout, self.backend.voice)
                raise MiketalkError("Festival stopped before it had spoken the text")
            self._buffer += block
        at = self._buffer.index(wanted) + len(wanted)
        self._errors += _MARKERS.sub("", self._buffer[:at].decode(errors="replace"))
        self._buffer = self._buffer[at:]
        if "SIOD ERROR" in self._errors:
            check_exit(1, self._errors, self.backend.voice)

    def close(self) -> None:
        """Kill Festival if it still runs; remove the scratch directory."""
        proc, self._proc = self._proc, None
        if proc is not None:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            for pipe in (proc.stdin, proc.stderr):
                if pipe is not None and not pipe.closed:
                    with suppress(BrokenPipeError):
                        pipe.close()
        self._stack.close()


_MARKERS = re.compile(r"miketalk: (planned|spoken) \d+\n")


class _Sentence(PendingSpeech):
    """One sentence of a :class:`FestivalSteps` run."""

    def __init__(self, run: FestivalSteps, index: int, text: str) -> None:
        super().__init__(run.backend, text)
        self.run, self.index = run, index

    def finish(self, retime: Retime) -> Utterance:
        return self.run.speak(self.index, self.text, retime)

    def close(self) -> None:
        """Nothing: the run is closed as a whole."""


def _join(text: str, utterances: list[Utterance]) -> Utterance:
    """Sentences' utterances joined one after the other (their chunks kept)."""
    from miketalk.speech.festival.output import Chunk

    chunks = [
        Chunk(u.text, u.samples, u.rate, tuple(p.name for p in u.phones),
              tuple(p.end for p in u.phones))
        for u in utterances
    ]  # fmt: skip
    return join_chunks(text, chunks)
