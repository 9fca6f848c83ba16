"""Sound: any media file's sound track decoded by ffmpeg (:func:`read_media_audio`, run with
an argument list, never through a shell); mono 16-bit PCM wav files read and written
(atomically) with the standard library."""

from __future__ import annotations

import numbers
import os
import struct
import subprocess
import wave
from collections.abc import Callable
from pathlib import Path

import numpy as np

from miketalk.console import child_process
from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_paths
from miketalk.media.ownership import WAV_SOFTWARE

_SAMPLE_WIDTH = 2  # bytes: int16
#: Seconds ffmpeg may take to decode one file's sound.
_TIMEOUT = 300.0


def check_samples(samples: object, name: str = "samples") -> np.ndarray:
    """Return ``samples`` after checking it is a 1-D int16 array.

    Raises
    ------
    MiketalkError
        Naming ``name``.
    """
    if not isinstance(samples, np.ndarray):
        raise MiketalkError(f"{name} must be a numpy int16 array, got {type(samples).__name__}")
    if samples.ndim != 1:
        raise MiketalkError(f"{name} must be 1-D (mono), got shape {samples.shape}")
    if samples.dtype != np.int16:
        raise MiketalkError(
            f"{name} must be int16, got dtype {samples.dtype}; scale floats in [-1, 1] "
            "by 32767 and convert with .astype(np.int16)"
        )
    return samples


def check_rate(rate: object, name: str = "rate") -> int:
    """Return ``rate`` as an int after checking it is a positive whole number of Hz."""
    if isinstance(rate, bool | np.bool_) or not isinstance(rate, numbers.Integral) or rate <= 0:
        raise MiketalkError(f"{name} must be a positive integer sample rate in Hz, got {rate!r}")
    return int(rate)


def write_wav(
    path: str | os.PathLike[str],
    samples: np.ndarray,
    rate: int,
    *,
    software: bool = False,
    guard: Callable[[], object] | None = None,
) -> None:
    """Write mono int16 ``samples`` at ``rate`` Hz to a PCM wav file, atomically.

    Parameters
    ----------
    path : path-like
        The wav file; its directory is created if needed.
    samples : ndarray of int16, shape (n,)
        The audio.
    rate : int
        Sample rate in Hz.
    software : bool
        Name miketalk as the file's software (a RIFF ``LIST``/``INFO`` chunk with ``ISFT``
        after the data): what tells a later run it may replace the file
        (:mod:`miketalk.media.ownership`).
    guard : callable, optional
        Run just before the file is published, under its lock
        (:func:`~miketalk.media.atomic.atomic_paths`).

    Raises
    ------
    MiketalkError
        If ``samples`` is not 1-D int16 or ``rate`` is not a positive integer.
    """
    samples = check_samples(samples)
    rate = check_rate(rate)
    data = samples.astype("<i2", copy=False).tobytes()
    # the 44-byte RIFF/WAVE header of mono 16-bit PCM, written with the data in one call
    # (the wave module's writer, interrupted by a signal while it opens, complains from
    # its __del__ on stderr)
    tail = b""
    if software:
        name = WAV_SOFTWARE + b"\0"
        info = b"INFO" + b"ISFT" + struct.pack("<I", len(name)) + name
        tail = (b"\0" if len(data) % 2 else b"") + b"LIST" + struct.pack("<I", len(info)) + info
    header = struct.pack(
        "<4sI4s4sIHHIIHH4sI",
        b"RIFF", 36 + len(data) + len(tail), b"WAVE", b"fmt ", 16, 1, 1, rate,
        rate * _SAMPLE_WIDTH, _SAMPLE_WIDTH, 8 * _SAMPLE_WIDTH, b"data", len(data),
    )  # fmt: skip
    with atomic_paths([path], guard=guard) as (tmp,):
        Path(tmp).write_bytes(header + data + tail)


def read_wav(path: str | os.PathLike[str]) -> tuple[np.ndarray, int]:
    """Read a mono 16-bit PCM wav file.

    Parameters
    ----------
    path : path-like
        The wav file.

    Returns
    -------
    samples : ndarray of int16, shape (n,)
        The audio.
    rate : int
        Sample rate in Hz.

    Raises
    ------
    MiketalkError
        If the file is missing, is not a PCM wav file, or is not mono 16-bit.
    """
    path = Path(path)
    if not path.is_file():
        raise MiketalkError(f"wav file not found: {path}")
    try:
        with wave.open(str(path), "rb") as wav:
            channels, width = wav.getnchannels(), wav.getsampwidth()
            rate, data = wav.getframerate(), wav.readframes(wav.getnframes())
    except (wave.Error, EOFError) as exc:
        raise MiketalkError(f"{path} is not a readable PCM wav file: {exc}") from exc
    if channels != 1 or width != _SAMPLE_WIDTH:
        raise MiketalkError(
            f"{path} has {channels} channel(s) of {8 * width}-bit samples; "
            "mono 16-bit PCM is required (convert with: ffmpeg -i IN -ac 1 -c:a pcm_s16le OUT.wav)"
        )
    return np.frombuffer(data, dtype="<i2").astype(np.int16), rate


def read_media_audio(
    path: str | Path,
    *,
    rate: int = 16000,
    start: float | None = None,
    duration: float | None = None,
) -> np.ndarray:
    """Decode the first audio stream of a media file to mono int16 at ``rate`` Hz.

    Channels are averaged; ffmpeg resamples. ``start`` and ``duration`` (seconds)
    decode a part only.

    Parameters
    ----------
    path : str or Path
        Any file ffmpeg reads (``.mpg``, ``.mp4``, ``.wav``, ...).
    rate : int
        Sample rate of the result in Hz.

    Returns
    -------
    numpy.ndarray
        int16 samples, shape ``(n,)``.

    Raises
    ------
    MiketalkError
        If the file is missing, has no audio stream, or ffmpeg cannot decode it;
        the message names the file.
    """
    import imageio_ffmpeg

    path = Path(path)
    if isinstance(rate, bool) or not isinstance(rate, int) or not 1000 <= rate <= 384000:
        raise MiketalkError(f"rate must be a whole number of Hz in 1000..384000, got {rate!r}")
    if not path.is_file():
        raise MiketalkError(f"cannot read audio from {path}: no such file")
    command = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-nostdin", "-hide_banner", "-loglevel", "error",
        *(["-ss", f"{start:.6f}"] if start else []),
        "-i", str(path.resolve()),
        *(["-t", f"{duration:.6f}"] if duration is not None else []),
        "-map", "0:a:0", "-vn", "-sn", "-dn",
        "-ac", "1", "-ar", str(rate), "-acodec", "pcm_s16le", "-f", "s16le",
        "pipe:1",
    ]  # fmt: skip
    try:
        with child_process(command) as proc:  # a signal stopping the run kills it
            out, err = proc.communicate(timeout=_TIMEOUT)
    except subprocess.TimeoutExpired:
        raise MiketalkError(f"ffmpeg took longer than {_TIMEOUT:.0f} s to decode {path}") from None
    code = proc.returncode
    errors = err.decode(errors="replace").strip()
    if code != 0:
        if "matches no streams" in errors:
            raise MiketalkError(f"{path} has no audio stream")
        tail = errors.splitlines()[-1] if errors else f"exit status {code}"
        raise MiketalkError(f"ffmpeg cannot decode the audio of {path}: {tail}")
    if len(out) < 2:
        raise MiketalkError(f"{path} has an empty audio stream")
    return np.frombuffer(out[: len(out) // 2 * 2], dtype="<i2").astype(np.int16)
