"""MP4 output (H.264 + AAC) through the ffmpeg binary bundled with imageio-ffmpeg.

:func:`write_mp4` is deterministic (the same frames and audio give a
byte-identical file) and atomic (the mp4 appears complete under its name, or
not at all, also on errors and Ctrl-C). It works inside a private temporary
directory (:func:`miketalk.media.scratch.scratch_dir`, removed whatever happens; one left by
a killed run is removed by the next):

1. the number of frames ``n`` is known in advance (the length of an array or
   sequence of frames, or ``n_frames=`` for an iterator, as ``miketalk say``
   streams its frames), so the audio is first padded with silence or trimmed
   to exactly ``round(n * rate / fps)`` samples and written to a wav;
2. the frames are piped as raw video to one ffmpeg run that encodes them to
   H.264 (yuv420p, ``-threads 1`` so the bitstream does not depend on the
   machine's core count) and the wav to AAC.

A recording given as a file (``audio_file=``, ``say --audio`` and ``dub --audio``) is
not decoded into memory: ffmpeg reads its first audio stream itself and encodes it to
AAC at the recording's own sample rate and channels (a 44.1 kHz stereo recording stays
44.1 kHz stereo; AAC at 96 kb/s for mono, 64 kb/s a channel for more, which is
transparent for speech), its samples counted from its first one, padded with silence or
cut to the same ``n / fps``.

So the audio and video streams have the same duration ``n / fps`` to within one
audio sample (well within one frame). :func:`probe_durations` measures both by
decoding the file.
"""

from __future__ import annotations

import logging
import math
import numbers
import os
import re
import subprocess
import sys
from collections.abc import Iterable, Iterator
from fractions import Fraction
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_path
from miketalk.media.audio import check_rate, check_samples, write_wav
from miketalk.media.ffmpeg_log import encoding_failure
from miketalk.media.probe import probe_durations
from miketalk.media.scratch import scratch_dir
from miketalk.media.x264 import FILE_X264, LIVE_X264, X264, ffmpeg_exe
from miketalk.media.yuv import I420Frame

if sys.platform == "linux":
    import fcntl
else:  # pragma: no cover - the pipe keeps its default size
    fcntl = None

__all__ = [
    "FILE_X264",
    "LIVE_X264",
    "X264",
    "audio_format",
    "ffmpeg_exe",
    "probe_durations",
    "write_mp4",
]

_BITEXACT = ["-fflags", "+bitexact", "-map_metadata", "-1"]
_AUDIO_BITRATE = "96k"
# ffmpeg's AAC encoder with its "fast" coder: on 14.5 s of Festival's 16 kHz speech
# 0.07 s of CPU instead of 0.20 s with the default "twoloop", at 40.0 dB SNR after
# decoding instead of 44.7 dB
_AAC_CODER = "fast"
_MAX_CRF = 51
_STDERR_TAIL = 15  # lines of ffmpeg's log quoted in errors
_PIPE_BYTES = 8 << 20  # wanted size of the pipe to ffmpeg


def write_mp4(
    path: str | os.PathLike[str],
    frames: Iterable[np.ndarray] | np.ndarray,
    *,
    fps: float,
    audio: np.ndarray | None = None,
    rate: int | None = None,
    n_frames: int | None = None,
    crf: int = 18,
    preset: str = FILE_X264.preset,
    audio_file: str | os.PathLike[str] | None = None,
    tune: str | None = None,
) -> None:
    """Write frames and mono audio to an H.264 (yuv420p) + AAC mp4, atomically and reproducibly.

    Parameters
    ----------
    path : path-like
        The mp4 file; its directory is created if needed.
    frames : iterable of ndarray, or ndarray
        ``(H, W, 3)`` RGB or ``(H, W)`` grey uint8 frames, all of one shape; or
        one ``(N, H, W, 3)`` / ``(N, H, W)`` array. An odd width or height (which
        yuv420p cannot hold) is padded by one by repeating the last column/row. Or
        :class:`~miketalk.media.yuv.I420Frame` frames, all of one size: encoded as they
        are, without ffmpeg's conversion from RGB.
    fps : float, keyword-only
        Frame rate, > 0 (a float such as 29.97 is turned into the nearest fraction).
    audio : ndarray of int16, shape (n,), keyword-only, optional
        Mono audio. It is padded with silence at the end, or trimmed at the end,
        to last exactly ``n_frames / fps`` (rounded to the nearest sample). None
        writes a file without an audio stream.
    rate : int, keyword-only
        Sample rate of ``audio`` in Hz; required with ``audio``.
    n_frames : int, keyword-only, optional
        How many frames ``frames`` holds; required when ``frames`` is an iterator
        without a length (the audio is fitted before the frames are made), and
        checked against the frames given: a different count is an error.
    crf : int, keyword-only
        x264 constant rate factor, 0 (lossless) to 51; 18 is visually lossless.
    preset : str, keyword-only
        x264 preset (speed/size trade-off; does not affect determinism).
    tune : str, keyword-only, optional
        x264 tune (e.g. ``film``); None: none (as both :data:`FILE_X264` and :data:`LIVE_X264`).
    audio_file : path-like, keyword-only, optional
        A recording whose first audio stream is the sound, at its own rate and channels
        (see the module docstring), instead of ``audio``.

    Raises
    ------
    MiketalkError
        On malformed arguments or frames (naming the argument or the frame), or if
        ffmpeg fails (quoting the end of its log). No file is left behind.
    """
    fps_q = _check_fps(fps)
    if isinstance(crf, bool) or not isinstance(crf, numbers.Integral) or not 0 <= crf <= _MAX_CRF:
        raise MiketalkError(f"crf must be an integer from 0 to {_MAX_CRF}, got {crf!r}")
    if audio is not None:
        audio = check_samples(audio, "audio")
        if rate is None:
            raise MiketalkError("rate (the audio sample rate in Hz) is required with audio")
        rate = check_rate(rate)
    if n_frames is not None and (
        isinstance(n_frames, bool) or not isinstance(n_frames, numbers.Integral) or n_frames < 1
    ):
        raise MiketalkError(f"n_frames must be a positive integer, got {n_frames!r}")
    if n_frames is None:
        if not hasattr(frames, "__len__"):
            raise MiketalkError(
                "n_frames is required when the frames are an iterator (the audio is fitted "
                "to the video's length before the frames are made)"
            )
        n_frames = len(frames)
        if n_frames < 1:
            raise MiketalkError("no frames to write: the frame list is empty")
    exe = ffmpeg_exe()
    with scratch_dir("mp4") as work:
        audio_args: tuple[list[str], list[str]] = ([], [])
        if audio_file is not None:
            if audio is not None:
                raise MiketalkError("give the audio as samples or as a file, not both")
            audio_args = _audio_file_input(exe, Path(audio_file), int(n_frames), fps_q)
        elif audio is not None and rate is not None:
            audio_args = _audio_input(work, audio, rate, int(n_frames), fps_q)
        with atomic_path(path, suffix=".mp4") as out:
            count = _encode_video(
                exe, _iter_frames(frames), fps_q, X264(preset, int(crf), tune), out,
                work / "video.log", *audio_args,
            )  # fmt: skip
            if count != n_frames:
                raise MiketalkError(f"{count} frames were given, not n_frames={n_frames}")


def _audio_input(
    work: Path, audio: np.ndarray, rate: int, n_frames: int, fps: Fraction
) -> tuple[list[str], list[str]]:
    """ffmpeg arguments adding ``audio``, fitted to ``n_frames / fps``, as the second input.

    Returns the input (``-i``) and the output stream options, to be placed
    after the inputs and after the video stream's options.
    """
    n_samples = round(Fraction(n_frames) * rate / fps)
    wav = work / "audio.wav"
    write_wav(wav, _fit(audio, n_samples), rate)
    return ["-i", str(wav)], [
        "-map", "1:a:0", "-c:a", "aac", "-aac_coder", _AAC_CODER, "-b:a", _AUDIO_BITRATE,
        "-flags:a", "+bitexact",
    ]  # fmt: skip


#: Channels of each layout name ffmpeg prints ("N channels" otherwise).
_LAYOUTS = {"mono": 1, "stereo": 2, "2.1": 3, "3.0": 3, "quad": 4, "4.0": 4, "5.0": 5, "5.1": 6,
            "6.1": 7, "7.1": 8}  # fmt: skip
_AUDIO_STREAM = re.compile(r"Stream #\S+.*?: Audio: [^,]+, (\d+) Hz, ([^,]+)")


def audio_format(path: str | os.PathLike[str]) -> tuple[int, int]:
    """The sample rate (Hz) and channels of a media file's first audio stream.

    Raises
    ------
    MiketalkError
        If the file has no audio stream ffmpeg can read.
    """
    proc = subprocess.run(
        [ffmpeg_exe(), "-hide_banner", "-nostdin", "-i", str(path)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    match = _AUDIO_STREAM.search(proc.stderr)
    if match is None:
        raise MiketalkError(f"{path} has no audio stream ffmpeg can read")
    layout = match[2].split("(")[0].strip()
    count = re.match(r"(\d+) channels", layout)
    channels = int(count[1]) if count else _LAYOUTS.get(layout, 2)
    return int(match[1]), channels


def _audio_file_input(
    exe: str, path: Path, n_frames: int, fps: Fraction
) -> tuple[list[str], list[str]]:
    """ffmpeg arguments adding the first audio stream of ``path`` at its own rate and channels,
    fitted to ``n_frames / fps`` (from its first sample), as the second input."""
    rate, channels = audio_format(path)
    n_samples = round(Fraction(n_frames) * rate / fps)
    bitrate = f"{max(96, 64 * channels)}k"
    fit = f"asetpts=N/SR/TB,apad=whole_len={n_samples},atrim=end_sample={n_samples}"
    return ["-i", str(path.resolve())], [
        "-map", "1:a:0", "-af", fit, "-c:a", "aac", "-aac_coder", _AAC_CODER, "-b:a", bitrate,
        "-ar", str(rate), "-flags:a", "+bitexact",
    ]  # fmt: skip


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------


def _check_fps(fps: object) -> Fraction:
    """``fps`` as an exact fraction (nearest with a denominator up to 1001)."""
    if isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not math.isfinite(fps):
        raise MiketalkError(f"fps must be a positive number, got {fps!r}")
    if fps <= 0:
        raise MiketalkError(f"fps must be positive, got {fps}")
    return Fraction(fps).limit_denominator(1001)


def _iter_frames(frames: Iterable[np.ndarray] | np.ndarray) -> Iterator[np.ndarray]:
    """Yield checked, even-sized, C-contiguous uint8 frames of one shape."""
    if isinstance(frames, np.ndarray):
        if frames.ndim == 3 and frames.shape[2] == 3:
            raise MiketalkError(
                f"frames has shape {frames.shape}, which looks like one RGB image; pass a "
                "list of frames or an (N, H, W, 3) array"
            )
        if frames.ndim not in (3, 4):
            raise MiketalkError(
                f"frames must be an (N, H, W, 3) or (N, H, W) array, got shape {frames.shape}"
            )
    elif not isinstance(frames, Iterable):
        raise MiketalkError(f"frames must be an iterable of images, got {type(frames).__name__}")
    first: tuple[int, ...] | None = None
    for i, frame in enumerate(frames):
        if isinstance(frame, I420Frame):  # already the encoder's colours (even-sized)
            shape = ("i420", *frame.planes.shape)
            if first is None:
                first = shape
            elif shape != first:
                raise MiketalkError(f"frame {i} is {shape} but frame 0 is {first}")
            yield I420Frame(np.ascontiguousarray(frame.planes, np.uint8))
            continue
        if not isinstance(frame, np.ndarray):
            raise MiketalkError(f"frame {i} is a {type(frame).__name__}, not a numpy array")
        if frame.dtype != np.uint8:
            raise MiketalkError(f"frame {i} has dtype {frame.dtype}; frames must be uint8")
        if first is None:
            if frame.ndim not in (2, 3) or (frame.ndim == 3 and frame.shape[2] != 3):
                raise MiketalkError(
                    f"frame 0 has shape {frame.shape}; frames must be (H, W, 3) RGB or (H, W) grey"
                )
            first = frame.shape
        elif frame.shape != first:
            raise MiketalkError(f"frame {i} has shape {frame.shape} but frame 0 has {first}")
        yield _even(frame)


def _even(frame: np.ndarray) -> np.ndarray:
    """Pad an odd height/width by repeating the last row/column (yuv420p needs even sizes)."""
    pad_h, pad_w = frame.shape[0] % 2, frame.shape[1] % 2
    if pad_h or pad_w:
        widths = ((0, pad_h), (0, pad_w)) + ((0, 0),) * (frame.ndim - 2)
        frame = np.pad(frame, widths, mode="edge")
    return np.ascontiguousarray(frame)


def _fit(audio: np.ndarray, n_samples: int) -> np.ndarray:
    """Trim ``audio`` to ``n_samples`` or pad it with silence (zeros) at the end."""
    if audio.size >= n_samples:
        return audio[:n_samples]
    return np.concatenate([audio, np.zeros(n_samples - audio.size, np.int16)])


def _encode_video(
    exe: str,
    frames: Iterator[np.ndarray],
    fps: Fraction,
    x264: X264,
    out: Path,
    log: Path,
    inputs: list[str],
    streams: list[str],
) -> int:
    """Pipe the frames to ffmpeg, H.264 into the mp4 ``out``; returns the frame count.

    ``inputs`` and ``streams`` add further inputs (the audio) and their output
    stream options, which come after the video's.
    """
    first = next(frames, None)
    if first is None:
        raise MiketalkError("frames is empty; a video needs at least one frame")
    if isinstance(first, I420Frame):
        (height, width), pix_fmt = first.size, "yuv420p"
    else:
        height, width = first.shape[:2]
        pix_fmt = "rgb24" if first.ndim == 3 else "gray"
    args = [
        "-f", "rawvideo", "-pix_fmt", pix_fmt, "-s", f"{width}x{height}",
        "-framerate", f"{fps.numerator}/{fps.denominator}", "-i", "pipe:0", *inputs,
        "-map", "0:v:0", *x264.args(),
        "-pix_fmt", "yuv420p", "-threads", "1", "-flags:v", "+bitexact", *streams, *_BITEXACT,
        "-movflags", "+faststart", "-f", "mp4", str(out),
    ]  # fmt: skip
    count = 0
    with log.open("wb") as err:
        proc = subprocess.Popen(
            [exe, "-hide_banner", "-nostats", "-loglevel", "error", "-y", *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        try:
            stdin = proc.stdin
            if stdin is None:  # pragma: no cover - Popen(stdin=PIPE) always sets it
                raise RuntimeError("no pipe to ffmpeg")
            _widen_pipe(stdin.fileno())
            for frame in _chain(first, frames):
                stdin.write(frame.planes.data if isinstance(frame, I420Frame) else frame.data)
                count += 1
            stdin.close()
            code = proc.wait()
        except BrokenPipeError:
            code = proc.wait()
        finally:
            if proc.poll() is None:  # an exception (bad frame, Ctrl-C) while ffmpeg runs
                proc.kill()
                proc.wait()
    if code != 0:
        text = log.read_text(errors="replace")
        logging.getLogger(__name__).info("ffmpeg's log:\n%s", _tail(text))
        raise encoding_failure(out.parent, text)
    return count


def _widen_pipe(fd: int) -> None:
    """Let the pipe to ffmpeg hold several frames (Linux; elsewhere a no-op).

    The default 64 KiB holds less than one 256x256 RGB frame, so rendering and
    encoding would wait on each other frame by frame; a pipe of up to
    ``/proc/sys/fs/pipe-max-size`` (1 MiB by default) lets them run side by side
    on two cores.
    """
    setsize = getattr(fcntl, "F_SETPIPE_SZ", None) if fcntl is not None else None
    if setsize is None:
        return
    for size in (_PIPE_BYTES, 1 << 20):
        try:
            fcntl.fcntl(fd, setsize, size)
            return
        except OSError:  # above the system's limit: try the default limit
            continue


def _chain(first: np.ndarray, rest: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
    yield first
    yield from rest


def _tail(text: str) -> str:
    lines = text.strip().splitlines()[-_STDERR_TAIL:]
    return "\n".join(lines) if lines else "(ffmpeg printed nothing)"
