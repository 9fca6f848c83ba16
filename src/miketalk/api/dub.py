"""``dub``: a video of the model's person made to say new speech, at the video's own size and
frame rate, his head moving as it does in the video.

Every frame of the video is registered to the model's reference
(:func:`miketalk.composite.for_model.video_background`: through its face crops for a
model built in one), the mouth is drawn for the speech at the video's own frame rate and
composited into every frame. Speech longer than the video plays it forwards, backwards,
forwards (no jump); shorter speech ends the video with it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.api.models import OpenModels, opened
from miketalk.api.results import DubResult
from miketalk.api.say import (
    Checked,
    Recorded,
    Speech,
    check,
    checked,
    engine,
    started,
    voice_of,
    write,
)
from miketalk.api.settings import DubSettings
from miketalk.errors import MiketalkError

if TYPE_CHECKING:
    from miketalk.talk.frames import Uttered
    from miketalk.talk.stream import Emitter, Stream

__all__ = ["dub", "dub_stream"]


def dub(
    video: str | os.PathLike[str],
    speech: Speech,
    output: str | os.PathLike[str] | int,
    settings: DubSettings | None = None,
    *,
    models: OpenModels | None = None,
    progress: bool = False,
    inputs: Sequence[str | os.PathLike[str] | None] = (),
) -> DubResult:
    """Make ``video`` of the model's person say ``speech``: an mp4 at ``output`` and its
    timeline JSON beside it; or a fragmented MP4 on a file descriptor.

    Parameters
    ----------
    video : path-like
        A frontal video of the model's person, steady light, at least a second long, at a
        constant frame rate.
    speech : str or Recorded
        Typed text (Festival speaks it), or a recording and what it says.
    output : path-like or int
        The ``.mp4`` to write (``NAME.json`` beside it); an int: a file descriptor to write
        a fragmented MP4 on as it is made (``miketalk dub ... -o -``).
    settings : DubSettings, optional
        The model (built from clips of the person; None, with no ``$MIKETALK_MODEL``: one
        built from ``video`` itself, kept in a cache by its checksum,
        :mod:`miketalk.api.video_model`), how the mouth moves, the voice.
    models : OpenModels, optional
        Models kept open between calls (the page's).
    progress : bool
        Draw progress bars on stderr.
    inputs : sequence of path-like
        Other files the caller read for this (a text file): never written over.

    Returns
    -------
    DubResult

    Raises
    ------
    MiketalkError
        In one line, before the work where it can be: a model not built from a person, a
        video that cannot be read, lasts less than a second or has a frame rate out of range;
        then a video whose frames do not show the model's person, or whose frames were not
        taken at a constant rate.
    """
    settings = settings if settings is not None else DubSettings()
    if not Path(video).is_file():
        raise MiketalkError(f"video file not found: {video}")
    if settings.model is None and not os.environ.get("MIKETALK_MODEL"):  # the video's own
        from miketalk.api.video_model import with_video_model

        settings = with_video_model(video, speech, output, settings, inputs=tuple(inputs),
                                    progress=progress)  # fmt: skip
    from miketalk.talk.recorded import aligning

    plan = None
    found: dict = {}
    # a recording's alignment started first, in a child, while the checks are made and the
    # video registers (killed on the way out unless taken: a failed check leaves nothing)
    with _started(aligning, speech) as pending:
        if not isinstance(output, int):
            plan = checked(speech, output, settings, inputs=(*inputs, video), dub=True)
        stream = _dub_stream(video, speech, settings, models, progress, plan, found, pending)
        spoken = write(stream, output, plan)
    background = found["background"]
    return DubResult(
        spoken, spoken.timeline.fps, settings.sampling, settings.step_limit,
        **voice_of(speech, settings), source=Path(video), size=tuple(background.size),
        source_frames=len(background), blinks=tuple(background.blinks),
    )  # fmt: skip


def dub_stream(
    video: str | os.PathLike[str],
    speech: Speech,
    settings: DubSettings | None = None,
    *,
    models: OpenModels | None = None,
    progress: bool = False,
) -> Stream:
    """``video`` of the model's person saying ``speech``, as a stream of timed chunks (as
    :func:`~miketalk.api.say.say_stream`; the video is registered before the first frame).

    Raises
    ------
    MiketalkError
        At once: no such video, and :func:`~miketalk.api.say.check`'s; the rest (a video
        that cannot be read or does not show the person) to the stream's reader.
    """
    settings = settings if settings is not None else DubSettings()
    return _dub_stream(video, speech, settings, models, progress, None, {})


def _dub_stream(
    video: str | os.PathLike[str],
    speech: Speech,
    settings: DubSettings,
    models: OpenModels | None,
    progress: bool,
    plan: Checked | None,
    found: dict,
    pending=None,
) -> Stream:
    """:func:`dub_stream`, its checks made (``plan``) or made here; ``found`` gets the
    registered ``background``; ``pending``: a recording's alignment started before
    (:func:`~miketalk.talk.recorded.aligning`; None: started by the stream's producer, whose
    stop then kills it)."""
    from miketalk.lipsync.settings import check_fps
    from miketalk.media.decode import video_info
    from miketalk.talk.stream import Stream

    if not Path(video).is_file():
        raise MiketalkError(f"video file not found: {video}")
    if plan is None:
        model_dir, chosen = check(settings, recorded=isinstance(speech, Recorded), dub=True)
    else:
        model_dir, chosen = plan.model_dir, plan.lipsync_model
    _, _, fps = video_info(video)
    try:
        check_fps(fps)
    except MiketalkError as err:
        raise MiketalkError(f"{video}: its frame rate: {err}") from None
    lipsync = settings.lipsync(fps, chosen)

    def produce(emitter: Emitter) -> Uttered:
        from miketalk.composite.for_model import video_background
        from miketalk.media.timing import check_constant_rate
        from miketalk.talk.recorded import aligning

        # Festival works, or a recording is aligned (in a child), while the video registers
        with started(speech, settings) as said, _started(aligning, said, pending) as ahead:
            with opened(model_dir, models, background="still") as (model, _):
                background = video_background(
                    model, video, progress=progress, check_person=settings.check_person
                )
                emitter.check()
                check_constant_rate(video, fps, len(background))  # shown when they were taken
                found["background"] = background
                aligned = ahead.result if ahead is not None else None
                return engine(said, lipsync, model, background, progress=progress,
                              aligned=aligned)(emitter)  # fmt: skip

    return Stream(produce, name="dub")


@contextmanager
def _started(aligning, said, before=None) -> Iterator:
    """A recording's alignment started (:func:`~miketalk.talk.recorded.aligning`), killed on
    the way out unless taken; None for typed text, or a recording aligned later. ``before``:
    one started earlier, used as it is (its starter's block kills it)."""
    from miketalk.talk.recorded import Recorded

    if before is not None:
        yield before
        return
    pending = aligning(said) if isinstance(said, Recorded) else None
    if pending is None:
        yield None
        return
    with pending:
        yield pending
