"""What a job does: speak with a model, or dub a video.

:func:`speak` makes the same library call as ``miketalk say`` or ``miketalk dub``
(:func:`miketalk.api.say`, :func:`miketalk.api.dub`), with the models the page keeps open,
and writes the mouth cues beside the mp4 (Rhubarb's JSON and TSV). A build runs in a
process of its own (:mod:`miketalk.serve.build`).
"""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from miketalk import api
from miketalk.api import (
    DubSettings,
    MiketalkError,
    OpenModels,
    Recorded,
    SayResult,
    SaySettings,
    Stream,
)
from miketalk.api.vocabulary import DEFAULT_VOICE
from miketalk.serve.live import LiveFile, record

log = logging.getLogger(__name__)


@dataclass
class Outcome:
    """What a finished job hands the page (``result``) and the files it may fetch (``files``:
    name -> path in the job's folder)."""

    result: dict[str, Any]
    files: dict[str, Path] = field(default_factory=dict)


def one_line(err: BaseException) -> str:
    """The line the page shows for a failure: a :class:`MiketalkError`'s own text, else what
    the command line says of a dead worker or a full disk, else a pointer to the log."""
    if isinstance(err, MiketalkError):
        return " ".join(str(err).split())
    if isinstance(err, BrokenProcessPool):
        return (
            "a worker process died (killed when memory or disk ran out?); the output was "
            "not written"
        )
    if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
        return "no space left on the disk"
    return "something went wrong on the server; its log has the details"


def speak(
    folder: Path,
    model_dir: Path | None,
    *,
    text: str | None,
    audio: Path | None = None,
    video: Path | None = None,
    lipsync: str | None = None,
    voice: str | None = None,
    warm: OpenModels | None = None,
    live: LiveFile | None = None,
    started: Callable[[Stream], None] = lambda stream: None,
) -> Outcome:
    """Make the model in ``model_dir`` say ``text`` (Festival, ``voice``) or the recording
    ``audio`` (with what it says, ``text``); over the frames of ``video`` when given (a dub):
    :func:`miketalk.api.say` or :func:`miketalk.api.dub`, as ``miketalk say`` and ``miketalk
    dub`` call them; or, ``live``, their streams written to ``live`` as they are made
    (:func:`miketalk.serve.live.record`), ``started(stream)`` told the stream first (a Stop
    cancels it).

    A dub with no ``model_dir`` is made with the video's own model
    (:func:`miketalk.api.own_model`: built from it the first time, minutes, before any
    frame; kept in the user's cache by its checksum, so the next dub of it starts at once).
    Writes ``say.mp4`` (``dub.mp4``) and its timeline ``.json``, ``cues.json`` and
    ``cues.tsv`` into ``folder``. ``warm`` keeps the model open for the next one.

    Raises
    ------
    MiketalkError
        What the library says of the input, in one line.
    Cancelled
        A live job's stream was stopped.
    """
    speech = Recorded(audio, text=text or None) if audio is not None else text or ""
    if model_dir is None and video is not None:  # a dub given no model: the video's own
        model_dir = api.own_model(video)[0]  # built once, kept by its checksum
    options = {"model": model_dir, "lipsync_model": lipsync or None, "voice": voice}
    if live is not None:
        settings = (DubSettings if video is not None else SaySettings)(**options)
        if video is not None:
            stream = api.dub_stream(video, speech, settings, models=warm)
        else:
            stream = api.say_stream(speech, settings, models=warm)
        started(stream)
        return _played(stream, live, folder / ("dub" if video else "say"), settings, speech)
    if video is not None:
        output = folder / "dub.mp4"
        said = api.dub(video, speech, output, DubSettings(**options), models=warm)
        extra = {"loops": "looped" if said.looped else "cut to the speech",
                 "source_frames": said.source_frames}  # fmt: skip
    else:
        output = folder / "say.mp4"
        said = api.say(speech, output, SaySettings(**options), models=warm)
        extra = {}
    return outcome(said, output, said.timeline_json, extra)


def _played(
    stream: Stream, live: LiveFile, stem: Path, settings: SaySettings | DubSettings, speech
) -> Outcome:
    """A live job's stream recorded (:func:`miketalk.serve.live.record`) into ``stem.mp4``,
    with its timeline ``stem.json`` and its cues; nothing of it is left if it fails."""
    output, timeline = stem.with_suffix(".mp4"), stem.with_suffix(".json")
    recorded = isinstance(speech, Recorded)
    try:
        spoken = record(stream, live, output)
        said = SayResult(
            spoken, spoken.timeline.fps, settings.sampling, settings.step_limit,
            max_slowdown=getattr(settings, "max_slowdown", None),
            voice=None if recorded else settings.voice or DEFAULT_VOICE,
            audio=Path(speech.audio).name if recorded else None,
        )  # fmt: skip
        doc = {"text": speech.text if recorded else speech, "lipsync_model": spoken.lipsync_model,
               "trajectory": spoken.trajectory, "duration": spoken.duration,
               "words": list(spoken.words)} | spoken.timeline.to_dict() | {
               "motion": spoken.motion.to_dict()}  # fmt: skip
        write_text(timeline, doc)
        return outcome(said, output, timeline, {})
    except BaseException:
        for path in (output, timeline, stem.with_name("cues.json"), stem.with_name("cues.tsv")):
            path.unlink(missing_ok=True)
        raise


def outcome(said: SayResult, output: Path, timeline: Path, extra: dict) -> Outcome:
    """The result of a say or dub written to ``output`` and its ``timeline``: the files,
    the summary and the mouth cues (written beside them)."""
    spoken = said.spoken
    duration = spoken.duration
    cues = said.cues()
    files = {output.name: output, timeline.name: timeline}
    for name, text in (
        ("cues.json", said.cues_text("json", sound_file=output.name)),
        ("cues.tsv", said.cues_text("tsv")),
    ):
        write_text(output.parent / name, text)
        files[name] = output.parent / name
    motion = spoken.motion
    drawn = f", {spoken.trajectory} trajectory" if spoken.trajectory else ""
    result = {
        "video": output.name,
        "timeline": timeline.name,
        "cues_json": "cues.json",
        "cues_tsv": "cues.tsv",
        "duration": duration,
        "frames": motion.frames,
        "fps": said.fps,
        "lipsync_model": spoken.lipsync_model,
        "trajectory": spoken.trajectory,
        "cues": [[c.start, c.end, c.value] for c in cues],
        "summary": f"{motion.frames} frames at {said.fps:g} fps, {duration:.2f} s of "
        f"speech ({spoken.lipsync_model} lip-sync{drawn})"
        + (
            f", over {extra['source_frames']} frames ({extra['loops']})" if "loops" in extra else ""
        ),
    }
    return Outcome(result, files)


class _Warned(logging.Handler):
    """The warnings the library logs from one thread, each handed to ``told``."""

    def __init__(self, told: Callable[[str], None]) -> None:
        super().__init__(logging.WARNING)
        self.told, self.thread = told, threading.get_ident()

    def filter(self, record: logging.LogRecord) -> bool:
        return record.thread == self.thread and record.levelno < logging.ERROR

    def emit(self, record: logging.LogRecord) -> None:
        self.told(" ".join(record.getMessage().split()))


@contextlib.contextmanager
def warnings_of(told: Callable[[str], None]) -> Iterator[None]:
    """Hand ``told`` each warning the library logs in this thread while the body runs (words
    read as spaces, a video that ends early): the page shows them; the server's log keeps
    its own line of each, once."""
    handler = _Warned(told)
    library = logging.getLogger("miketalk")
    library.addHandler(handler)
    try:
        yield
    finally:
        library.removeHandler(handler)


def write_text(path: Path, text: str | dict) -> None:
    """Write ``text`` to ``path`` through a temporary file beside it (whole or not at all);
    a ``dict`` as JSON, written as it is encoded (``json.dumps`` would hold an hour's
    timeline, 30 MB of text, as some 200 MB of pieces before joining them)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as out:
            if isinstance(text, str):
                out.write(text)
            else:
                json.dump(text, out, indent=1, allow_nan=False)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
