"""The writers of an utterance's stream: the mp4 and its timeline JSON, or fragmented MP4 on
a pipe.

:func:`publish` reads a :class:`~miketalk.talk.stream.Stream` into ``NAME.mp4`` and, beside
it, ``NAME.json`` (the timeline of its frames and the measures of their motion, then the
mp4's name, size and SHA-256: what tells a later run that miketalk wrote it,
:mod:`miketalk.media.ownership`). The two are published as one unit
(:func:`miketalk.media.atomic.atomic_paths`: the old pair or the new, never one of each; on
any failure, Ctrl-C or SIGTERM included, an older pair is left as it was); what killed runs
left beside the output is settled first, and the output is checked again, under its lock,
just before it is replaced.

:func:`pipe_out` writes the same frames as a fragmented MP4 on a file descriptor
(``miketalk say ... -o -``): a player plays it as it comes.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Sequence
from pathlib import Path

from miketalk.errors import MiketalkError
from miketalk.media.atomic import atomic_paths, sweep_beside
from miketalk.media.encoder import StreamEncoder
from miketalk.media.ownership import file_record
from miketalk.media.scratch import scratch_dir
from miketalk.talk.frames import Uttered
from miketalk.talk.output import TIMELINE_FORMAT, check_output
from miketalk.talk.stream import Cancelled, Stream
from miketalk.talk.utterance import Spoken

__all__ = ["encode", "pipe_out", "publish"]

log = logging.getLogger(__name__)


def encode(stream: Stream, out: Path | int, work: Path, *, live: bool = False) -> Uttered:
    """Read ``stream`` to its end into one ffmpeg (:class:`StreamEncoder`) writing ``out``;
    return what the engine made. A stop or an error kills ffmpeg and the engine's work.
    ``live``: x264's live settings (:data:`~miketalk.media.x264.LIVE_X264`), else the file's."""
    from miketalk.media.x264 import FILE_X264, LIVE_X264

    with stream:
        info = stream.info()
        try:
            with StreamEncoder(
                out, fps=info.fps, rate=None if info.sound else info.rate, sound=info.sound,
                n_frames=info.frames, log_path=work / "video.log", on_start=stream.adopt,
                x264=LIVE_X264 if live else FILE_X264,
            ) as encoder:  # fmt: skip
                for chunk in stream:
                    encoder.add(chunk.frame, None if info.sound else chunk.audio)
                encoder.finish()
        except Exception:
            if stream.cancelled:  # ffmpeg killed by the stop: the stop is what happened
                raise Cancelled("the stream was stopped") from None
            raise
    if not isinstance(stream.result, Uttered):
        raise RuntimeError("the stream's engine returned no utterance")
    return stream.result


def publish(
    stream: Stream,
    output: str | os.PathLike[str],
    *,
    overwrite: bool = False,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> Spoken:
    """Write ``stream`` to the mp4 ``output`` and its timeline JSON beside it, as one unit.

    Parameters
    ----------
    stream : Stream
        The utterance (started here, after the output's checks).
    output : path-like
        The ``.mp4``; ``NAME.json`` is written beside it.
    overwrite : bool
        Replace an mp4 or a ``NAME.json`` that miketalk did not write (never an input).
    inputs : sequence of path-like
        What the utterance reads: never written over.

    Returns
    -------
    Spoken
        The timeline, the motion, the files written.

    Raises
    ------
    MiketalkError
        The output (before any work), the engine's errors, ffmpeg's.
    """
    output = check_output(output, overwrite=overwrite, inputs=inputs)
    sweep_beside(output)
    json_path = output.with_suffix(".json")

    def guard() -> None:  # what the output is now, under its lock, before it is replaced
        check_output(output, overwrite=overwrite, inputs=inputs)

    try:
        with (
            scratch_dir("mp4") as work,
            atomic_paths([output, json_path], guard=guard) as (video_tmp, json_tmp),
        ):
            uttered = encode(stream, video_tmp, work)
            doc = (
                {"format": TIMELINE_FORMAT}
                | uttered.timeline.to_dict()
                | uttered.extra
                | {
                    "largest_step_px": uttered.motion.largest_step_px,
                    "motion": uttered.motion.to_dict(),
                }
                | {"mp4": file_record(video_tmp) | {"name": output.name}}
            )
            try:  # written as it is encoded: an hour's timeline is never held as text
                with open(json_tmp, "w", encoding="utf-8") as out:
                    json.dump(doc, out, indent=1, allow_nan=False)
            except ValueError as err:
                raise MiketalkError(
                    f"the timeline of {output} holds a value JSON cannot: {err}"
                ) from None
    finally:
        stream.close()
    log.info("wrote %s (%d frames)", output, uttered.motion.frames)
    return uttered.spoken(output, json_path)


def pipe_out(stream: Stream, fd: int, *, live: bool = True) -> Spoken:
    """Write ``stream`` as a fragmented MP4 on the file descriptor ``fd`` (a pipe, a
    terminal's redirection, a socket) as it is made; no JSON. ``live`` (``-o -``, the page):
    x264's live settings (no look-ahead: each frame leaves the encoder at once; its frames
    then differ slightly from the file's); False: the file's (the same frames as the file).

    Raises
    ------
    MiketalkError
        The engine's errors, ffmpeg's (a reader that went away: its log says so).
    """
    try:
        with scratch_dir("pipe") as work:
            uttered = encode(stream, fd, work, live=live)
    finally:
        stream.close()
    return uttered.spoken(None, None)
