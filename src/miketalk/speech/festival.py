"""Festival (voice_kal_diphone) as a subprocess: text -> wav + timed radio phones.

The Scheme program is package data (``scheme/synthesize.scm``); text and
settings reach it through environment variables only, so user text is never
parsed as Scheme (Festival's Scheme can run shell commands).

numpy is imported inside the functions that build arrays, not at the top: so
``miketalk say`` can start Festival (:meth:`FestivalBackend.start`) before
numpy has loaded, and the two overlap.
"""

from __future__ import annotations

import os
import re
import select
import shutil
import subprocess
import tempfile
import time
import wave
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from functools import cached_property
from importlib import resources
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.errors import MiketalkError
from miketalk.speech.backend import PendingSpeech, Retime, SpeechBackend, register
from miketalk.speech.text import normalize_text, split_chunks
from miketalk.speech.types import Phone, Utterance

if TYPE_CHECKING:
    import numpy as np

APT_PACKAGES = "festival festvox-kallpc16k"
_INSTALL_HINT = f"install it with: apt-get install -y {APT_PACKAGES}"


@dataclass(frozen=True)
class _Chunk:
    text: str
    samples: np.ndarray
    rate: int
    names: tuple[str, ...]
    ends: tuple[float, ...]


@register
class FestivalBackend(SpeechBackend):
    """Festival run as ``festival -b synthesize.scm``.

    Parameters
    ----------
    executable : str, optional
        Path to ``festival``; else ``$MIKETALK_FESTIVAL``; else ``festival`` on PATH.
    voice : str
        Festival voice function; only ``voice_kal_diphone`` is supported (its
        phone set is the radio set that the viseme table maps).
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
        voice: str = "voice_kal_diphone",
        max_words: int = 40,
        timeout: float = 600.0,
        heap: int = 1_000_000,
    ) -> None:
        self.executable = executable or os.environ.get("MIKETALK_FESTIVAL") or "festival"
        self.voice = voice
        self.max_words = max_words
        self.timeout = timeout
        if isinstance(heap, bool) or not isinstance(heap, int) or heap < 100_000:
            raise MiketalkError(f"heap must be an integer of at least 100000 cells, got {heap!r}")
        self.heap = heap

    # -- availability -----------------------------------------------------------------
    def _path(self) -> str:
        path = shutil.which(self.executable)
        if path is None:
            raise MiketalkError(f"Festival not found ({self.executable!r}); {_INSTALL_HINT}")
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
        chunks = self._run(split_chunks(clean, max_words=self.max_words), None)
        return _join(clean, chunks)

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
        return [_join(t, [c]) for t, c in zip(clean, self._run(clean, None), strict=True)]

    def resynthesize(self, utterance: Utterance, durations: Sequence[float]) -> Utterance:
        """Speak ``utterance`` again with dictated phone durations (seconds).

        The text is re-read through the modules up to Duration, each Segment's
        end is set from ``durations``, then Int_Targets and Wave_Synth run.

        Raises
        ------
        MiketalkError
            Wrong number of durations, a non-positive or non-finite duration, or
            Festival producing other phones than ``utterance`` has.
        """
        texts = split_chunks(utterance.text, max_words=self.max_words)
        sizes = [n for _, n in utterance.chunks] if utterance.chunks else [len(utterance.phones)]
        if len(sizes) != len(texts):
            raise MiketalkError("the utterance's chunks do not match its text; synthesize it again")
        chunks = self._run(texts, _chunk_ends(durations, sizes))
        _check_same_phones(chunks, [p.name for p in utterance.phones])
        return _join(utterance.text, chunks)

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

    def start(self, text: str) -> _FestivalRun:
        """Start Festival on ``text`` now; :meth:`PendingSpeech.finish` dictates the durations.

        Festival starts, loads its voice and predicts the phones while the
        caller goes on; ``finish`` waits for the prediction, hands it to
        ``retime``, and lets Festival make the wave.

        Raises
        ------
        MiketalkError
            Nothing speakable in ``text``, or Festival missing.
        """
        return _FestivalRun(self, text)

    @contextmanager
    def _workspace(self, texts: list[str]) -> Iterator[tuple[Path, dict[str, str], list[str]]]:
        """A scratch directory, the environment carrying ``texts``, and the command line."""
        festival = self._path()
        scheme = resources.files("miketalk.speech").joinpath("scheme/synthesize.scm")
        with (
            tempfile.TemporaryDirectory(prefix="miketalk-festival-") as tmp,
            resources.as_file(scheme) as scheme_path,
        ):
            env = {
                "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
                "HOME": tmp,
                "MIKETALK_VOICE": self.voice,
                "MIKETALK_OUT": tmp,
                "MIKETALK_CHUNKS": str(len(texts)),
            }
            for i, chunk_text in enumerate(texts):
                env[f"MIKETALK_TEXT_{i}"] = chunk_text
            yield Path(tmp), env, [festival, "--heap", str(self.heap), "-b", str(scheme_path)]

    def _run(self, texts: list[str], ends: list[tuple[float, ...]] | None) -> list[_Chunk]:
        with self._workspace(texts) as (tmp, env, command):
            if ends is not None:
                for i, chunk_ends in enumerate(ends):
                    path = _write_ends(tmp, i, chunk_ends)
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
            _check_exit(proc.returncode, proc.stderr + proc.stdout)
            return [_read_chunk(tmp, i, t) for i, t in enumerate(texts)]


_PLANNED = "miketalk: planned"

#: voice_kal_diphone's sample rate: places chunk boundaries of the predicted phones
#: exactly where the spoken chunks' wavs will put them.
_VOICE_RATE = 16000


class _FestivalRun(PendingSpeech):
    """One Festival run in plan mode: started at once, finished with dictated durations.

    Festival analyses the text, writes each chunk's predicted phones and ends,
    prints :data:`_PLANNED` on stderr and waits for one datum on stdin; ``finish``
    writes the dictated ends (if any) before sending it, then Festival makes
    the waves. The text reaches Festival only through the environment.
    """

    def __init__(self, backend: FestivalBackend, text: str) -> None:
        clean = normalize_text(text)
        super().__init__(backend, clean)
        self._texts = split_chunks(clean, max_words=backend.max_words)
        self._deadline = time.monotonic() + backend.timeout
        self._stack = ExitStack()
        self._proc: subprocess.Popen | None = None
        try:
            tmp, env, command = self._stack.enter_context(backend._workspace(self._texts))
            env["MIKETALK_PLAN"] = "1"
            self._tmp = tmp
            stdout = self._stack.enter_context((tmp / "stdout").open("w"))
            self._proc = subprocess.Popen(
                command, env=env, cwd=tmp, stdin=subprocess.PIPE, stdout=stdout,
                stderr=subprocess.PIPE,
            )  # fmt: skip
        except BaseException:
            self.close()
            raise

    def finish(self, retime: Retime) -> Utterance:
        """Wait for Festival's phones, dictate ``retime``'s durations, return the utterance."""
        proc, tmp, texts = self._proc, self._tmp, self._texts
        if proc is None:
            raise MiketalkError("this Festival run was already finished or closed")
        try:
            errors = _read_until(proc, _PLANNED, self._deadline, self.backend.timeout)
            if _PLANNED not in errors:
                proc.wait(timeout=max(self._deadline - time.monotonic(), 0.1))
                _check_exit(proc.returncode or 1, errors + (tmp / "stdout").read_text())
            planned = [_read_plan(tmp, i, t) for i, t in enumerate(texts)]
            durations = retime(_join(self.text, planned).phones)
            if durations is not None:
                sizes = [len(c.names) for c in planned]
                for i, chunk_ends in enumerate(_chunk_ends(durations, sizes)):
                    _write_ends(tmp, i, chunk_ends)
            try:
                proc.stdin.write(b"go\n")
                proc.stdin.close()
            except BrokenPipeError:  # Festival died after planning: its exit says why
                pass
            rest = _read_until(proc, None, self._deadline, self.backend.timeout)
            proc.wait(timeout=max(self._deadline - time.monotonic(), 0.1))
            stdout = (tmp / "stdout").read_text(errors="replace")
            _check_exit(proc.returncode, errors + rest + stdout)
            chunks = [_read_chunk(tmp, i, t) for i, t in enumerate(texts)]
            _check_same_phones(chunks, [name for c in planned for name in c.names])
            return _join(self.text, chunks)
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


def _read_until(proc: subprocess.Popen, marker: str | None, deadline: float, timeout: float) -> str:
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


def _check_exit(returncode: int, messages: str) -> None:
    """A clear error when Festival failed (status, or an SIOD error on any stream)."""
    errors = messages.strip()
    if returncode != 0 or "SIOD ERROR" in errors:
        if "voice_kal_diphone" in errors and "unbound" in errors:
            raise MiketalkError(f"Festival's kal voice is missing; {_INSTALL_HINT}")
        tail = "\n".join(errors.splitlines()[-5:])
        raise MiketalkError(f"Festival failed (exit {returncode}):\n{tail}")


def _write_ends(directory: Path, index: int, ends: Sequence[float]) -> Path:
    """Chunk ``index``'s dictated Segment ends as one Scheme list of numbers."""
    path = directory / f"{index}.ends"
    path.write_text("(" + " ".join(f"{e:.6f}" for e in ends) + ")\n")
    return path


def _chunk_ends(durations: Sequence[float], sizes: Sequence[int]) -> list[tuple[float, ...]]:
    """Split checked whole-utterance phone durations into each chunk's cumulative ends.

    ``sizes`` holds each chunk's number of phones.
    """
    import numpy as np  # here, not at the top: see the module docstring

    durations = _check_durations(durations, sum(sizes))
    bounds = np.cumsum([0, *sizes])
    return [tuple(np.cumsum(durations[a:b]).tolist()) for a, b in pairwise(bounds)]


def _check_same_phones(chunks: list[_Chunk], names: list[str]) -> None:
    """A re-synthesis must speak the phones the durations were dictated for."""
    if [name for c in chunks for name in c.names] != names:
        raise MiketalkError("Festival produced different phones on re-synthesis")


def _check_durations(durations: Sequence[float], n: int) -> np.ndarray:
    import numpy as np  # here, not at the top: see the module docstring

    durations = np.asarray(durations, dtype=np.float64)
    if durations.shape != (n,):
        raise MiketalkError(f"{durations.size} durations given for {n} phones")
    if not np.all(np.isfinite(durations)) or np.any(durations <= 0):
        raise MiketalkError("every phone duration must be a positive number of seconds")
    return durations


def _read_plan(directory: Path, index: int, text: str) -> _Chunk:
    """Chunk ``index``'s predicted phones, with silent samples as long as the phones."""
    import numpy as np  # here, not at the top: see the module docstring

    names, ends = _read_phones(directory / f"{index}.plan", text)
    n = round(ends[-1] * _VOICE_RATE)
    return _Chunk(text, np.zeros(n, np.int16), _VOICE_RATE, names, ends)


def _read_phones(path: Path, text: str) -> tuple[tuple[str, ...], tuple[float, ...]]:
    if not path.exists():
        raise MiketalkError(f"Festival wrote no output for {text!r}")
    names, ends = [], []
    for line in path.read_text().splitlines():
        name, end = line.split()
        names.append(name)
        ends.append(float(end))
    if not names:
        raise MiketalkError(f"Festival returned no phones for {text!r}")
    return tuple(names), tuple(ends)


def _read_chunk(directory: Path, index: int, text: str) -> _Chunk:
    import numpy as np  # here, not at the top: see the module docstring

    wav_path = directory / f"{index}.wav"
    if not wav_path.exists():
        raise MiketalkError(f"Festival wrote no output for {text!r}")
    names, ends = _read_phones(directory / f"{index}.phones", text)
    with wave.open(str(wav_path), "rb") as w:
        if w.getsampwidth() != 2 or w.getnchannels() != 1:
            raise MiketalkError("Festival's wav is not 16-bit mono")
        rate = w.getframerate()
        samples = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").astype(np.int16)
    # The kal voice runs ~25 ms past the last phone: cut the wav at its end (or
    # pad with silence) so that audio and phones end on the same sample.
    n = round(ends[-1] * rate)
    samples = samples[:n] if len(samples) >= n else np.pad(samples, (0, n - len(samples)))
    return _Chunk(text, samples, rate, names, ends)


def _join(text: str, chunks: list[_Chunk]) -> Utterance:
    """Concatenate chunks; each chunk's times are offset by the samples before it."""
    import numpy as np  # here, not at the top: see the module docstring

    rate = chunks[0].rate
    phones: list[Phone] = []
    offset = 0
    start = 0.0
    for chunk in chunks:
        # a chunk's last phone ends exactly on its last sample (it moves < half a
        # sample), so the next chunk's phones start exactly where its wav does
        stops = [offset / rate + end for end in chunk.ends[:-1]]
        offset += len(chunk.samples)
        stops.append(offset / rate)
        for name, stop in zip(chunk.names, stops, strict=True):
            phones.append(Phone(name, start, stop))
            start = stop
    samples = np.concatenate([c.samples for c in chunks])
    return Utterance(
        text=text,
        samples=samples,
        rate=rate,
        phones=tuple(phones),
        chunks=tuple((c.text, len(c.names)) for c in chunks),
    )
