"""Where ``say`` writes, checked before any work (with the standard library only: the CLI
checks it before Festival starts, and Festival starts before numpy loads).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from miketalk.errors import MiketalkError
from miketalk.media.atomic import check_writable

#: The ``format`` of the timeline JSON :func:`miketalk.talk.say.say` writes.
TIMELINE_FORMAT = "miketalk-timeline/1"


def is_timeline(path: Path) -> bool:
    """Whether ``path`` holds a timeline JSON miketalk wrote (any version)."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    if not isinstance(doc, dict):
        return False
    return doc.get("format") == TIMELINE_FORMAT or {"fps", "frames", "transitions"} <= set(doc)


def check_output(output: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
    """Check that ``output`` and its JSON can be written, before any work; return it.

    The directory is created if needed and a file is made (and removed)
    there, so a directory that cannot be written in is found now, not after
    the render.

    Parameters
    ----------
    output : path-like
        The ``.mp4`` to write; ``NAME.json`` is written beside it.
    overwrite : bool
        Replace a ``NAME.json`` that miketalk did not write.

    Raises
    ------
    MiketalkError
        Not an ``.mp4`` name; the mp4 or the JSON name is a directory; a
        ``NAME.json`` that is not a miketalk timeline (unless ``overwrite``);
        a directory that cannot be created or written in.
    """
    output = Path(output)
    if output.suffix.lower() != ".mp4":
        raise MiketalkError(f"output must be an .mp4 file, not {output.name!r}")
    timeline = output.with_suffix(".json")
    for path, what in ((output, "the video"), (timeline, "the timeline")):
        if path.is_dir():
            raise MiketalkError(
                f"{path} is a directory; say writes {what} there: give another -o "
                "(or move the directory)"
            )
        if path.exists() and not path.is_file():
            raise MiketalkError(f"{path} is not a regular file; say writes {what} there")
    if timeline.is_file() and not overwrite and not is_timeline(timeline):
        raise MiketalkError(
            f"{timeline} exists and is not a miketalk timeline; say writes the timeline of "
            f"{output.name} there: move it, give another -o, or overwrite it with --force"
        )
    if output.parent.exists() and not output.parent.is_dir():
        raise MiketalkError(f"cannot write {output}: {output.parent} is not a directory")
    check_writable(output)
    return output
