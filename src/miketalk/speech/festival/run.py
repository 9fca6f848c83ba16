"""One Festival run in plan mode (started at once, finished with dictated durations) and the
handling of its process: reading its stderr within a deadline, reporting how it ended.
"""

from __future__ import annotations

import os
import select
import subprocess
import time
from contextlib import AbstractContextManager, ExitStack
from pathlib import Path
from typing import Protocol

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
from miketalk.speech.festival.voices import VOICES, Voice, install_hint
from miketalk.speech.text import check_spoken_length, normalize_text, split_chunks
from miketalk.speech.types import Utterance


class FestivalSession(Protocol):
    """What a run needs of its backend (:class:`~miketalk.speech.festival.FestivalBackend`)."""

    voice: Voice
    max_words: int
    timeout: float

    def _workspace(
        self, texts: list[str]
    ) -> AbstractContextManager[tuple[Path, dict[str, str], list[str]]]:
        """A scratch directory holding ``texts``, the environment, and the command line."""
        ...


#: Festival and every voice miketalk knows (the Makefile installs them).
APT_PACKAGES = " ".join(["festival", *(v.package for v in VOICES.values())])


PLANNED = "miketalk: planned"


def start_festival(
    stack: ExitStack, backend: FestivalSession, texts: list[str], mode: str
) -> tuple[Path, subprocess.Popen]:
    """Festival started on ``texts`` in a workspace that ``stack`` removes when it closes,
    with the driver's environment flag ``mode`` (``MIKETALK_PLAN``, ``MIKETALK_STEPS``) set;
    its standard output goes to the workspace's ``stdout`` file. The workspace and the
    process."""
    tmp, env, command = stack.enter_context(backend._workspace(texts))
    env[mode] = "1"
    stdout = stack.enter_context((tmp / "stdout").open("w"))
    proc = subprocess.Popen(
        command, env=env, cwd=tmp, stdin=subprocess.PIPE, stdout=stdout,
        stderr=subprocess.PIPE,
    )  # fmt: skip
    return tmp, proc


class FestivalRun(PendingSpeech):
    """One Festival run in plan mode: started at once, finished with dictated durations.

    Festival analyses the text, writes each chunk's predicted phones and ends,
    prints :data:`PLANNED` on stderr and waits for one datum on stdin; ``finish``
    writes the dictated ends (if any) before sending it, then Festival makes
    the waves. The text reaches Festival only through files in its scratch directory.
    """

    def __init__(self, backend: FestivalSession, text: str) -> None:
        clean = normalize_text(text)
        check_spoken_length(clean)
        super().__init__(backend, clean)
        self._texts = split_chunks(clean, max_words=backend.max_words)
        self._deadline = time.monotonic() + backend.timeout
        self._stack = ExitStack()
        self._proc: subprocess.Popen | None = None
        try:
            self._tmp, self._proc = start_festival(
                self._stack, backend, self._texts, "MIKETALK_PLAN"
            )
        except BaseException:
            self.close()
            raise

    def finish(self, retime: Retime) -> Utterance:
        """Wait for Festival's phones, dictate ``retime``'s durations, return the utterance."""
        proc, tmp, texts = self._proc, self._tmp, self._texts
        voice = self.backend.voice
        if proc is None:
            raise MiketalkError("this Festival run was already finished or closed")
        try:
            errors = read_until(proc, PLANNED, self._deadline, self.backend.timeout)
            if PLANNED not in errors:
                proc.wait(timeout=max(self._deadline - time.monotonic(), 0.1))
                check_exit(proc.returncode or 1, errors + (tmp / "stdout").read_text(), voice)
            planned = [read_plan(tmp, i, t, voice.rate) for i, t in enumerate(texts)]
            durations = retime(join_chunks(self.text, planned).phones)
            ends = None
            if durations is not None:
                check_follows_durations(voice)
                ends = split_ends(durations, [len(c.names) for c in planned])
                for i, chunk_ends in enumerate(ends):
                    write_ends(tmp, i, chunk_ends)
            try:
                proc.stdin.write(b"go\n")
                proc.stdin.close()
            except BrokenPipeError:  # Festival died after planning: its exit says why
                pass
            rest = read_until(proc, None, self._deadline, self.backend.timeout)
            proc.wait(timeout=max(self._deadline - time.monotonic(), 0.1))
            stdout = (tmp / "stdout").read_text(errors="replace")
            check_exit(proc.returncode, errors + rest + stdout, voice)
            chunks = [read_chunk(tmp, i, t) for i, t in enumerate(texts)]
            check_same_phones(chunks, [name for c in planned for name in c.names])
            if ends is not None:
                check_followed(chunks, ends)
            return join_chunks(self.text, chunks)
        except subprocess.TimeoutExpired:
            raise MiketalkError(f"Festival took longer than {self.backend.timeout:.0f} s") from None
        finally:
            self.close()

    def close(self) -> None:
        """Kill Festival if it still runs; remove the scratch directory."""
        proc, self._proc = self._proc, None
        if proc is not None:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            for pipe in (proc.stdin, proc.stderr):
                if pipe is not None and not pipe.closed:
                    pipe.close()
        self._stack.close()


def read_until(proc: subprocess.Popen, marker: str | None, deadline: float, timeout: float) -> str:
    """Festival's stderr up to the line ``marker`` (None: to its end), within ``deadline``.

    Stops early at the end of the stream (Festival exited). Raises MiketalkError
    when the deadline passes first.
    """
    fd = proc.stderr.fileno()
    text = b""
    while marker is None or marker.encode() not in text:
        left = deadline - time.monotonic()
        if left <= 0:
            raise MiketalkError(f"Festival took longer than {timeout:.0f} s")
        ready, _, _ = select.select([fd], [], [], left)
        if ready:
            block = os.read(fd, 65536)
            if not block:
                break  # end of the stream: Festival exited
            text += block
    return text.decode(errors="replace")


def check_exit(returncode: int, messages: str, voice: Voice) -> None:
    """A clear error when Festival failed (status, or an SIOD error on any stream)."""
    errors = messages.strip()
    if returncode != 0 or "SIOD ERROR" in errors:
        if voice.function in errors and "unbound" in errors:
            raise MiketalkError(f"Festival's {voice.name} voice is missing; {install_hint(voice)}")
        tail = "\n".join(errors.splitlines()[-5:])
        raise MiketalkError(f"Festival failed (exit {returncode}):\n{tail}")
