"""Frames and their sound encoded as they come: an mp4 file, or fragmented MP4 on a pipe.

:class:`StreamEncoder` is :func:`miketalk.media.video.write_mp4`'s encoder fed one frame
(and the sound that plays while it shows) at a time, when the utterance's length is not
known in advance (typed text is spoken sentence by sentence). ffmpeg reads the frames as raw
video on its stdin and the sound as raw 16-bit samples on a second pipe, written by a
thread of their own (ffmpeg reads its inputs in threads of its own: one pipe blocked
never stalls the other). Its settings are ``write_mp4``'s (H.264 yuv420p, x264's
``veryfast`` preset at crf 18, one thread, AAC, bit-exact), so:

- the mp4 **file** (``-movflags +faststart``) is byte for byte what ``write_mp4`` writes
  for the same frames and samples;
- the **fragmented** MP4 (``frag_keyframe+empty_moov+delay_moov+default_base_moof``, a fragment at
  least every :data:`FRAGMENT_SECONDS`) carries the same H.264 stream, so a player
  decodes the same frames, and it can be played as it is written (``| ffplay -``,
  MediaSource in a browser).

A recording's sound (``sound=``) is read by ffmpeg from its file at its own rate and
channels, fitted to the frames' length (which must then be known: ``n_frames``).
"""

from __future__ import annotations

import logging
import os
import queue
import subprocess
import threading
from pathlib import Path
from typing import IO

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.ffmpeg_log import encoding_failure
from miketalk.media.video import (
    _AAC_CODER,
    _AUDIO_BITRATE,
    _BITEXACT,
    _audio_file_input,
    _check_fps,
    _even,
    _tail,
    _widen_pipe,
)
from miketalk.media.x264 import FILE_X264, X264, ffmpeg_exe
from miketalk.media.yuv import I420Frame

__all__ = ["FRAGMENT_SECONDS", "StreamEncoder"]

log = logging.getLogger(__name__)

#: The longest a fragment of a fragmented MP4 lasts (s): what a player waits for at most
#: before its first frame (three frames at 30 fps). 0.5 s held the page's first frame some
#: 0.25 s longer (on s1, the first byte 0.29 s after the drawing started against 0.54 s,
#: medians of 5 at load 10); the fragments' headers add some 2 kB a second.
FRAGMENT_SECONDS = 0.1


class StreamEncoder:
    """One ffmpeg encoding frames and mono samples as they are given.

    Parameters
    ----------
    out : Path or int
        The mp4 file to write (a complete, fast-start mp4), or a file descriptor to write a
        fragmented MP4 on (a pipe; ffmpeg writes it directly).
    fps : float
        Frames a second.
    rate : int or None
        Sample rate of the samples given to :meth:`add` (None: no sound, or ``sound``).
    sound : path-like, optional
        A recording whose first audio stream is the sound (its own rate and channels).
    n_frames : int, optional
        How many frames will be given: required with ``sound`` (its sound is fitted to them).
    log_path : Path
        Where ffmpeg's log goes (quoted when it fails).
    on_start : callable, optional
        Given the ffmpeg process once started (a stream adopts it, to kill it on a stop).
    x264 : X264
        x264's settings (:data:`~miketalk.media.x264.FILE_X264`, the file's, by default;
        :data:`~miketalk.media.x264.LIVE_X264` for a stream watched as it is made: ``-o -``
        and the page; faster, its frames then differ slightly).
    """

    def __init__(
        self,
        out: Path | int,
        *,
        fps: float,
        rate: int | None,
        log_path: Path,
        sound: str | os.PathLike[str] | None = None,
        n_frames: int | None = None,
        on_start=None,
        x264: X264 = FILE_X264,
    ) -> None:
        if sound is not None and n_frames is None:
            raise MiketalkError("a recording's sound is fitted to the frames: give n_frames")
        self.out, self.fps, self.rate, self.sound = out, _check_fps(fps), rate, sound
        self.n_frames, self.log_path, self.on_start = n_frames, log_path, on_start
        self.x264 = x264
        self.count = 0
        self._proc: subprocess.Popen | None = None
        self._audio: _Feeder | None = None
        self._log: IO[bytes] | None = None
        self._shape: tuple[int, ...] | None = None

    def add(self, frame: np.ndarray | I420Frame, audio: np.ndarray | None = None) -> None:
        """Encode ``frame`` ((H, W, 3) RGB or (H, W) grey uint8, all of one shape) and
        ``audio``: the mono int16 samples played while it shows (none with ``sound``)."""
        i420 = isinstance(frame, I420Frame)
        if self._proc is None:
            self._start(frame)
        shape = ("i420", *frame.planes.shape) if i420 else frame.shape
        if shape != self._shape:
            raise MiketalkError(f"frame {self.count} has shape {shape}, not {self._shape}")
        if audio is not None and self._audio is not None and len(audio):
            self._audio.put(np.ascontiguousarray(audio, dtype="<i2").tobytes())
        try:
            self._proc.stdin.write(frame.planes.data if i420 else _even(frame).data)
        except BrokenPipeError:
            self._fail()
        self.count += 1

    def finish(self) -> None:
        """Close the inputs and wait for ffmpeg to write the end of the file.

        Raises
        ------
        MiketalkError
            No frame was given, a count other than ``n_frames``, or ffmpeg failed (its log
            quoted; a full disk is a :class:`~miketalk.errors.MachineFailure`).
        BrokenPipeError
            The reader of a pipe went away (``| head``).
        """
        if self._proc is None:
            raise MiketalkError("no frames to write: a video needs at least one frame")
        if self.n_frames is not None and self.count != self.n_frames:
            raise MiketalkError(f"{self.count} frames were given, not n_frames={self.n_frames}")
        if self._audio is not None:
            self._audio.close()
        try:
            self._proc.stdin.close()
        except BrokenPipeError:
            pass
        code = self._proc.wait()
        if self._audio is not None:
            self._audio.join()
        self._close_log()
        if code != 0:
            self._fail()

    def kill(self) -> None:
        """Stop ffmpeg now (an error, a stop); idempotent."""
        proc = self._proc
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
        if self._audio is not None:
            self._audio.abandon()
        if proc is not None and proc.stdin is not None:
            try:
                proc.stdin.close()
            except BrokenPipeError:
                pass
        self._close_log()

    def __enter__(self) -> StreamEncoder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.kill()

    # -- inside -----------------------------------------------------------------------------
    def _start(self, first: np.ndarray | I420Frame) -> None:
        if isinstance(first, I420Frame):  # already the encoder's colours (even-sized)
            self._shape = ("i420", *first.planes.shape)
            (height, width), pix_fmt = first.size, "yuv420p"
        else:
            rgb = first.ndim == 3 and first.shape[2] == 3
            if first.dtype != np.uint8 or not (rgb or first.ndim == 2):
                raise MiketalkError(
                    f"frames must be (H, W, 3) or (H, W) uint8, not {first.shape} {first.dtype}"
                )
            self._shape = first.shape
            height, width = _even(first).shape[:2]
            pix_fmt = "rgb24" if rgb else "gray"
        fps = self.fps
        inputs: list[str] = []
        streams: list[str] = []
        pass_fds: tuple[int, ...] = ()
        read_end = None
        if self.sound is not None:
            inputs, streams = _audio_file_input(
                ffmpeg_exe(), Path(self.sound), int(self.n_frames), fps
            )
        elif self.rate is not None:
            read_end, write_end = os.pipe()
            pass_fds = (read_end,)
            inputs = ["-f", "s16le", "-ar", str(self.rate), "-ac", "1", "-i", f"pipe:{read_end}"]
            streams = [
                "-map", "1:a:0", "-c:a", "aac", "-aac_coder", _AAC_CODER, "-b:a", _AUDIO_BITRATE,
                "-flags:a", "+bitexact",
            ]  # fmt: skip
            self._audio = _Feeder(write_end)
        if isinstance(self.out, int):
            frag = f"{round(FRAGMENT_SECONDS * 1e6)}"
            target = ["-movflags", "frag_keyframe+empty_moov+delay_moov+default_base_moof",
                      "-frag_duration", frag, "-f", "mp4", "pipe:1"]  # fmt: skip
            stdout = self.out
        else:
            target = ["-movflags", "+faststart", "-f", "mp4", str(self.out)]
            stdout = subprocess.DEVNULL
        args = [
            "-f", "rawvideo", "-pix_fmt", pix_fmt, "-s", f"{width}x{height}",
            "-framerate", f"{fps.numerator}/{fps.denominator}", "-i", "pipe:0", *inputs,
            "-map", "0:v:0", *self.x264.args(), "-pix_fmt", "yuv420p", "-threads", "1",
            "-flags:v", "+bitexact", *streams, *_BITEXACT, *target,
        ]  # fmt: skip
        self._log = self.log_path.open("wb")
        try:
            self._proc = subprocess.Popen(
                [ffmpeg_exe(), "-hide_banner", "-nostats", "-loglevel", "error", "-y", *args],
                stdin=subprocess.PIPE, stdout=stdout, stderr=self._log, pass_fds=pass_fds,
            )  # fmt: skip
        finally:
            if read_end is not None:
                os.close(read_end)
        if self.on_start is not None:
            self.on_start(self._proc)
        _widen_pipe(self._proc.stdin.fileno())
        if self._audio is not None:
            _widen_pipe(self._audio.fd)
            self._audio.start()

    def _close_log(self) -> None:
        if self._log is not None and not self._log.closed:
            self._log.close()

    def _fail(self) -> None:
        self.kill()
        text = self.log_path.read_text(errors="replace") if self.log_path.exists() else ""
        log.info("ffmpeg's log:\n%s", _tail(text))
        if isinstance(self.out, int) and "Broken pipe" in text:
            raise BrokenPipeError("the reader of the video went away")  # `| head`: quietly
        folder = self.out.parent if isinstance(self.out, Path) else Path(".")
        raise encoding_failure(folder, text)


class _Feeder:
    """A thread writing byte blocks to a pipe, in order, so that the writer never waits on
    ffmpeg's reading of this input while ffmpeg waits for another."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self._blocks: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="miketalk-audio", daemon=True)
        self._abandoned = False
        self._lock = threading.Lock()

    def start(self) -> None:
        self._thread.start()

    def put(self, block: bytes) -> None:
        self._blocks.put(block)

    def close(self) -> None:
        self._blocks.put(None)

    def join(self) -> None:
        self._thread.join()

    def abandon(self) -> None:
        self._abandoned = True
        self._blocks.put(None)
        if not self._thread.is_alive():
            self._close_fd()

    def _run(self) -> None:
        try:
            while (block := self._blocks.get()) is not None and not self._abandoned:
                view = memoryview(block)
                while view:
                    view = view[os.write(self.fd, view) :]
        except OSError:  # ffmpeg is gone: its exit status says why
            pass
        finally:
            self._close_fd()

    def _close_fd(self) -> None:
        with self._lock:
            fd, self.fd = self.fd, -1
        if fd >= 0:
            os.close(fd)
