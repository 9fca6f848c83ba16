"""A dub's model when none is given: one built from the dubbed video itself, kept by its checksum.

``miketalk dub VIDEO --audio REC -o OUT.mp4`` with no ``--model`` (and no ``$MIKETALK_MODEL``)
is one command, as the tools users compare miketalk with have it: the model is built from
``VIDEO`` (:func:`miketalk.api.build.build`, nothing held back, its words recognized when it
comes without a script), kept in the cache under the video's SHA-256, then the dub is made
with it. A second dub of the same video finds the model there and starts at once. The cache
is the user's miketalk cache (:func:`miketalk.media.user_cache.cache_root`: ``$MIKETALK_CACHE``,
else ``$XDG_CACHE_HOME/miketalk``, else ``~/.cache/miketalk``), its folder ``video-models``; a
model there is a model like any other (delete its folder to build it again).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

from miketalk.api.settings import BuildSettings
from miketalk.errors import MiketalkError

__all__ = ["video_digest", "video_model", "with_video_model"]

log = logging.getLogger(__name__)

#: The folder of the user's cache that keeps them.
KIND = "video-models"


def video_digest(video: str | os.PathLike[str]) -> str:
    """The SHA-256 of the video file's bytes, in hex."""
    from miketalk.media.user_cache import file_digest

    return file_digest(video)


def video_model(video: str | os.PathLike[str], *, progress: bool = False) -> tuple[Path, bool]:
    """The model of ``video`` in the cache, built there when it is not yet.

    Returns
    -------
    (Path, bool)
        The model's folder, and whether it was built now (False: found in the cache).

    Raises
    ------
    MiketalkError
        What :func:`miketalk.api.build.build` raises of the video (no face, no speech, too
        little speech, ...); no cache to keep the model in.
    """
    from miketalk.api.build import build
    from miketalk.media.user_cache import CACHE_ENV, cache_dir
    from miketalk.model.parts import is_model

    where = cache_dir(KIND)
    if where is None:
        raise MiketalkError(
            f"no --model given, and no cache to build the video's own model in (${CACHE_ENV} "
            "is off, or cannot be written): give --model"
        )
    folder = where / video_digest(video)[:32]
    if is_model(folder):
        log.info("%s: its model, built before, is %s", video, folder)
        return folder, False
    log.warning(
        "%s: no model given: building one from the video itself (its words recognized) into "
        "%s; a dub of the same video later starts from it", video, folder,
    )  # fmt: skip
    build(video, folder, BuildSettings(heldout_seconds=0.0), progress=progress)
    return folder, True


def with_video_model(
    video: str | os.PathLike[str],
    speech: object,
    output: str | os.PathLike[str] | int,
    settings,
    *,
    inputs: tuple = (),
    progress: bool = False,
):
    """``settings`` (:class:`~miketalk.api.settings.DubSettings` without a model) with the
    model of ``video`` (:func:`video_model`), once the output and the recording's settings
    are checked: a mistake there is said before the build, not after it."""
    from dataclasses import replace

    from miketalk.api.settings import check_recorded_speech
    from miketalk.talk.output import check_output
    from miketalk.talk.speech import Recorded

    recorded = isinstance(speech, Recorded)
    if recorded:
        check_recorded_speech(settings)
    heard = (speech.audio, speech.timings) if recorded else ()
    if not isinstance(output, int):  # an int: a pipe (``-o -``), nothing to check
        check_output(output, overwrite=settings.overwrite, inputs=(*inputs, video, *heard))
    folder, _built = video_model(video, progress=progress)
    return replace(settings, model=folder)
