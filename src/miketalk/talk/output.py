"""Where ``say`` writes, checked before any work (with the standard library only: the CLI
checks it before Festival starts, and Festival starts before numpy loads).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from miketalk.errors import MiketalkError
from miketalk.media.atomic import check_writable
from miketalk.media.ownership import (
    TIMELINE_FORMAT,
    Kind,
    check_replaceable,
    written_by_miketalk,
)

__all__ = ["TIMELINE_FORMAT", "check_output", "is_timeline"]


def is_timeline(path: Path) -> bool:
    """Whether ``path`` holds a timeline JSON miketalk wrote (any version)."""
    return written_by_miketalk(path, Kind.TIMELINE)


def check_output(
    output: str | os.PathLike[str],
    *,
    overwrite: bool = False,
    inputs: Iterable[str | os.PathLike[str] | None] = (),
) -> Path:
    """Check that ``output`` and its JSON can be written, before any work; return it.

    The rule of :func:`miketalk.media.ownership.check_replaceable`: an existing mp4 is
    replaced only when the timeline JSON beside it names it (miketalk wrote the pair), an
    existing JSON only when it is a miketalk timeline, and neither may be an input. The
    directory is created if needed and a file is made (and removed) there, so a directory
    that cannot be written in is found now, not after the render.

    Parameters
    ----------
    output : path-like
        The ``.mp4`` to write; ``NAME.json`` is written beside it.
    overwrite : bool
        Replace an mp4 or a ``NAME.json`` that miketalk did not write (``--force``).
    inputs : iterable of path-like
        What the utterance reads (a recording, a text file, a video): never written over.

    Raises
    ------
    MiketalkError
        Not an ``.mp4`` name; the mp4 or the JSON name is a directory; a file miketalk
        did not write (unless ``overwrite``) or an input; a directory that cannot be
        created or written in.
    """
    output = Path(output)
    if output.suffix.lower() != ".mp4":
        raise MiketalkError(f"output must be an .mp4 file, not {output.name!r}")
    if output.parent.exists() and not output.parent.is_dir():
        raise MiketalkError(f"cannot write {output}: {output.parent} is not a directory")
    check_replaceable(output, Kind.VIDEO, inputs=inputs, force=overwrite)
    check_writable(output)
    return output
