"""What a job does: speak with a model, or dub a video.

:func:`speak` calls the library's entry points as ``miketalk say`` and ``miketalk dub`` do
(:func:`miketalk.talk.say.say` with the lip-sync model settled by
:func:`miketalk.draw.registry.choose_lipsync_model`, Festival started first with the voice
asked for; a dub's video registered to the model by
:func:`miketalk.composite.background_files.video_background`), and writes the mouth cues
beside the mp4 (:mod:`miketalk.lipsync.cues`, Rhubarb's JSON and TSV). A build runs in a
process of its own (:mod:`miketalk.serve.build`).
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from miketalk.errors import MiketalkError

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


class Warm:
    """The last models opened, kept open with their person's frames for the next ``say``
    (one thread's: the speech worker's). A model whose manifest changed, or one of whose
    files changed since it was opened (:meth:`~miketalk.model.face.Model.changed_on_disk`), is
    opened again, and so checked again."""

    def __init__(self, keep: int = 2) -> None:
        self.keep = keep
        self._open: dict[tuple[str, float], tuple[Any, Any]] = {}

    def get(self, model_dir: Path) -> tuple[Any, Any]:
        """The model in ``model_dir`` and its ``auto`` background (None: a still face).

        Raises
        ------
        MiketalkError
            No model there, or one that cannot be opened.
        """
        from miketalk.composite.background_files import resolve_background
        from miketalk.model.face import open_model

        try:
            key = (os.path.realpath(model_dir), (model_dir / "manifest.json").stat().st_mtime)
        except OSError:
            key = (os.path.realpath(model_dir), 0.0)
        if key in self._open and self._open[key][0].changed_on_disk():
            self._open.pop(key)[0].close()
        if key not in self._open:
            model = open_model(model_dir)
            try:
                background = resolve_background("auto", model)
            except BaseException:
                model.close()
                raise
            self._open[key] = (model, background)
            while len(self._open) > self.keep:
                oldest = next(iter(self._open))
                self._open.pop(oldest)[0].close()
        self._open[key] = self._open.pop(key)  # the most recent last
        return self._open[key]

    def close(self) -> None:
        """Close the models kept open."""
        for model, _ in self._open.values():
            model.close()
        self._open.clear()


def speak(
    folder: Path,
    model_dir: Path,
    *,
    text: str | None,
    audio: Path | None = None,
    video: Path | None = None,
    lipsync: str | None = None,
    voice: str = "kal",
    warm: Warm | None = None,
) -> Outcome:
    """Make the model in ``model_dir`` say ``text`` (Festival, ``voice``) or the recording
    ``audio`` (with what it says, ``text``); over the frames of ``video`` when given (a dub).

    Writes ``say.mp4`` (``dub.mp4``) and its timeline ``.json``, ``cues.json`` and
    ``cues.tsv`` into ``folder``. ``warm`` keeps the model open for the next one.

    Raises
    ------
    MiketalkError
        What the library says of the input, in one line.
    """
    from miketalk.lipsync.settings import LipsyncSettings
    from miketalk.model.parts import choose_lipsync_model

    recorded = audio is not None
    if not recorded and not (text or "").strip():
        raise MiketalkError("no text: type what the face should say, or give a recording")
    chosen = choose_lipsync_model(model_dir, lipsync or None, recorded=recorded)
    name = "dub" if video is not None else "say"
    output = folder / f"{name}.mp4"
    if video is not None:
        spoken, extra = _dub(output, model_dir, text, audio, video, chosen, voice, warm)
    else:
        from miketalk.speech import get_backend
        from miketalk.talk.say import Recorded, say

        settings = LipsyncSettings(model=chosen)
        with contextlib.ExitStack() as stack:
            speech = (
                Recorded(audio, text=text or None)
                if recorded
                else stack.enter_context(get_backend("festival", voice=voice).start(text))
            )  # Festival works while the model opens
            if warm is None:
                warm = stack.enter_context(contextlib.closing(Warm(keep=1)))
            model, background = warm.get(model_dir)
            spoken = say(speech, output, model=model, settings=settings, background=background)
        extra = {"fps": settings.fps}
    return _outcome(spoken, output, extra)


def _dub(output, model_dir, text, audio, video, chosen, voice, warm):
    """``miketalk dub``'s library calls (:func:`miketalk.cli.dub.cmd_dub`)."""
    from miketalk.composite.background_files import video_background
    from miketalk.lipsync.settings import LipsyncSettings, check_fps
    from miketalk.media.decode import video_info
    from miketalk.model.background import has_background
    from miketalk.speech import get_backend
    from miketalk.talk.say import Recorded, say

    if not has_background(model_dir):
        raise MiketalkError(
            f"the model {model_dir} was not built from video of a person: dub needs a model "
            "built from clips of the person in the video"
        )
    _, _, fps = video_info(video)
    try:
        check_fps(fps)
    except MiketalkError as err:
        raise MiketalkError(f"{video}: its frame rate: {err}") from None
    settings = LipsyncSettings(fps=fps, model=chosen)
    with contextlib.ExitStack() as stack:
        speech = (
            Recorded(audio, text=text or None)
            if audio is not None
            else stack.enter_context(get_backend("festival", voice=voice).start(text))
        )  # Festival works while the video registers
        if warm is None:
            warm = stack.enter_context(contextlib.closing(Warm(keep=1)))
        model = warm.get(model_dir)[0]
        background = video_background(model, video)
        spoken = say(speech, output, model=model, settings=settings, background=background)
    loops = "looped" if spoken.motion.frames > len(background) else "cut to the speech"
    return spoken, {"fps": fps, "source_frames": len(background), "loops": loops}


def _outcome(spoken, output: Path, extra: dict) -> Outcome:
    """The result of a say or dub: the files, the summary and the mouth cues."""
    from miketalk.lipsync.cues import mouth_cues, rhubarb_json, rhubarb_tsv
    from miketalk.visemes import default_table

    duration = spoken.duration
    cues = mouth_cues(spoken.timeline.phones, default_table(), duration=duration)
    files = {output.name: output, spoken.timeline_json.name: spoken.timeline_json}
    for name, text in (
        ("cues.json", rhubarb_json(cues, sound_file=output.name, duration=duration)),
        ("cues.tsv", rhubarb_tsv(cues, duration=duration)),
    ):
        write_text(output.parent / name, text)
        files[name] = output.parent / name
    motion = spoken.motion
    drawn = f", {spoken.trajectory} trajectory" if spoken.trajectory else ""
    result = {
        "video": output.name,
        "timeline": spoken.timeline_json.name,
        "cues_json": "cues.json",
        "cues_tsv": "cues.tsv",
        "duration": duration,
        "frames": motion.frames,
        "fps": extra["fps"],
        "lipsync_model": spoken.lipsync_model,
        "trajectory": spoken.trajectory,
        "cues": [[c.start, c.end, c.value] for c in cues],
        "summary": f"{motion.frames} frames at {extra['fps']:g} fps, {duration:.2f} s of "
        f"speech ({spoken.lipsync_model} lip-sync{drawn})"
        + (
            f", over {extra['source_frames']} frames ({extra['loops']})" if "loops" in extra else ""
        ),
    }
    return Outcome(result, files)


def write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file beside it (whole or not at all)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
