"""The sound track of a media file (video or audio) as mono int16 samples, through ffmpeg.

ffmpeg comes from :mod:`imageio_ffmpeg` (a binary shipped in the wheel) and is
run with an argument list, never through a shell.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

#: Seconds ffmpeg may take to decode one file.
_TIMEOUT = 300.0


def read_media_audio(path: str | Path, *, rate: int = 16000) -> np.ndarray:
    """Decode the first audio stream of a media file to mono int16 at ``rate`` Hz.

    Channels are averaged; ffmpeg resamples.

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
        "-i", str(path.resolve()),
        "-map", "0:a:0", "-vn", "-sn", "-dn",
        "-ac", "1", "-ar", str(rate), "-acodec", "pcm_s16le", "-f", "s16le",
        "pipe:1",
    ]  # fmt: skip
    try:
        proc = subprocess.run(command, capture_output=True, timeout=_TIMEOUT, check=False)
    except subprocess.TimeoutExpired:
        raise MiketalkError(f"ffmpeg took longer than {_TIMEOUT:.0f} s to decode {path}") from None
    errors = proc.stderr.decode(errors="replace").strip()
    if proc.returncode != 0:
        if "matches no streams" in errors:
            raise MiketalkError(f"{path} has no audio stream")
        tail = errors.splitlines()[-1] if errors else f"exit status {proc.returncode}"
        raise MiketalkError(f"ffmpeg cannot decode the audio of {path}: {tail}")
    if len(proc.stdout) < 2:
        raise MiketalkError(f"{path} has an empty audio stream")
    return np.frombuffer(proc.stdout[: len(proc.stdout) // 2 * 2], dtype="<i2").astype(np.int16)
