"""Speak, live: the face's fragmented MP4 played in the page while the rest is being made.

A live job reads the library's stream (:func:`miketalk.api.say_stream`) into its fragmented
MP4 writer (:func:`miketalk.api.write_fragmented`), which writes on a pipe; a relay thread
copies the pipe into the job's ``live.mp4`` as it comes (:class:`LiveFile`), and any number
of the page's requests follow that file as it grows (:func:`follow`, ``GET
/api/jobs/<id>/live``): a tab that opens late, or a second tab, gets the whole stream from its
start. A slow or gone reader never holds the engine (the file is on disk; the engine's own
queue holds at most its 16 frames): the frames held do not grow with the text's length (the
timeline and the sound the result keeps do: docs/serve.md, "An hour's text").

When the stream has ended the fragments are put into one mp4 with its index at the front
(``say.mp4``: the same H.264 and AAC packets, copied, not encoded again) for the download
(:func:`record`); :func:`miketalk.serve.work.speak` writes the timeline and the mouth cues
beside it, as for a job that is not live. A Stop
(:meth:`Stream.cancel <miketalk.api.Stream.cancel>`) ends the work and every process it
started at once; the job ends ``cancelled`` and keeps nothing but its record.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import subprocess
import threading
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

from miketalk import api
from miketalk.api import MiketalkError, Stream

#: The name of a live job's fragmented MP4 while it is made.
LIVE_FILE = "live.mp4"
#: Seconds between two looks at a live file that has not grown.
FOLLOW_POLL = 0.01
_BLOCK = 1 << 16


class LiveFile:
    """A job's fragmented MP4 as it is written: its path, how many bytes are there, and
    whether it is whole (or will grow no more).

    Parameters
    ----------
    path : Path
        Where the bytes go (created by :meth:`relay`).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.size = 0
        self.ended = False
        self.started = threading.Event()

    def relay(self, read_fd: int) -> None:
        """Copy what comes on ``read_fd`` into the file until its end (its own thread); the
        pipe's read end is closed after."""
        try:
            with open(read_fd, "rb", buffering=0) as pipe, open(self.path, "wb") as out:
                self.started.set()
                while block := pipe.read(_BLOCK):
                    out.write(block)
                    out.flush()
                    self.size += len(block)
        finally:
            self.ended = True
            self.started.set()


async def follow(live: LiveFile, until: Callable[[], bool]) -> AsyncIterator[bytes]:
    """The bytes of ``live`` from its start as they are written, until it has ended (or
    ``until()`` says the job is over before it started)."""
    while not live.started.is_set():
        if until():
            return
        await asyncio.sleep(FOLLOW_POLL)
    if not live.path.exists():
        return
    with open(live.path, "rb") as f:
        sent = 0
        while True:
            size, ended = live.size, live.ended
            if sent < size:
                block = f.read(min(size - sent, 1 << 20))
                sent += len(block)
                yield block
                continue
            if ended:
                return
            await asyncio.sleep(FOLLOW_POLL)


def record(stream: Stream, live: LiveFile, output: Path) -> Any:
    """Write ``stream`` as a fragmented MP4 (:func:`miketalk.api.write_fragmented`, x264's
    live settings: :data:`~miketalk.media.x264.LIVE_X264`) into
    ``live`` as it is made, then the whole into ``output`` (:func:`whole`); ``live``'s file
    is removed after. Returns what the library says was written (its timeline, its motion).

    Raises
    ------
    MiketalkError
        What the library says of the input, in one line.
    Cancelled
        The stream was stopped.
    """
    read_fd, write_fd = os.pipe()
    relay = threading.Thread(target=live.relay, args=(read_fd,), name="miketalk-live", daemon=True)
    relay.start()
    try:
        try:
            spoken = api.write_fragmented(stream, write_fd, live=True)
        finally:
            os.close(write_fd)
            relay.join()
        whole(live.path, output)
        return spoken
    finally:
        live.path.unlink(missing_ok=True)


def whole(fragments: Path, output: Path) -> None:
    """The fragmented MP4 ``fragments`` as one mp4 with its index at the front, the same
    packets copied (ffmpeg ``-c copy -movflags +faststart``), written whole or not at all.

    Raises
    ------
    MiketalkError
        ffmpeg failed.
    """
    import imageio_ffmpeg

    tmp = output.with_name(f".{output.name}.{os.getpid()}.tmp.mp4")
    try:
        done = subprocess.run(
            [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-y", "-i",
             str(fragments), "-map", "0", "-c", "copy", "-movflags", "+faststart",
             "-fflags", "+bitexact", str(tmp)],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or ["no word"])[-1]
            raise MiketalkError(f"ffmpeg could not put the stream into one mp4: {last}")
        os.replace(tmp, output)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
