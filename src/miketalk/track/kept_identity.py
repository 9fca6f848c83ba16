"""The identity check's verdict on a video, kept for the next run: a second ``dub`` of the
same video with the same model does not look at its faces again.

:func:`~miketalk.track.identity.check_person` measures how far the faces of frames spread
over a video are from the model's reference face (:func:`~miketalk.track.identity.
person_distance`): ffmpeg decoding to each of its frames and dlib's descriptors, 2 s of CPU
on a 10-s 720p video, on every ``dub`` without ``--force``. The distance depends only on the
video's bytes, the reference's pixels and the code that measures it, so
:func:`kept_distance` keeps it in the user's cache (:mod:`miketalk.media.user_cache`, kind
:data:`KIND`) under a name made of all of them:

- the video's SHA-256 (its bytes, read each time: a file changed in place is another key);
- the reference's SHA-256 (its shape and pixels: the model's face it is compared with);
- the package's version, the SHA-256 of the source of what measures it (:data:`_MAKERS`),
  dlib's version and ffmpeg's path, size and time (its decoding).

The distance is kept, not the verdict: the verdict is made from it each time against
:data:`~miketalk.track.identity.MAX_DISTANCE`, so a video of another person is refused on
the second try as on the first, before any work. An entry that cannot be read, or whose
distance is not a number a measure gives, is measured again (and written again). Without a
cache (``$MIKETALK_CACHE=off``) it is measured every time, as before.
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
from collections.abc import Callable

import numpy as np

__all__ = ["KIND", "identity_key", "kept_distance"]

log = logging.getLogger(__name__)

#: The kind of cache entry (:func:`~miketalk.media.user_cache.cache_dir`).
KIND = "identities"

#: The entry's layout; a change makes every old entry another key.
FORMAT = 1

#: The product's modules whose source measures the distance (their bytes are in the key).
_MAKERS = (
    "track/identity.py", "track/detect.py", "track/sampled_frames.py", "media/decode.py",
    "stabilize/faces.py", "stabilize/kept_detector.py",
)  # fmt: skip


def _array_digest(image: np.ndarray) -> str:
    """The SHA-256 of an array's dtype, shape and pixels."""
    array = np.ascontiguousarray(image)
    digest = hashlib.sha256(f"{array.dtype.str}{array.shape}".encode())
    digest.update(array.tobytes())
    return digest.hexdigest()


def identity_key(reference: np.ndarray, video: str | os.PathLike[str]) -> list:
    """What names the distance of ``video``'s faces to ``reference``'s (module docstring)."""
    import dlib

    from miketalk import __version__
    from miketalk.media.user_cache import ffmpeg_stamp, file_digest, source_digest

    return [
        FORMAT, __version__, source_digest(_MAKERS), dlib.__version__, ffmpeg_stamp(),
        file_digest(video), _array_digest(reference),
    ]  # fmt: skip


def _kept(record: object) -> tuple[bool, float | None]:
    """Whether ``record`` holds a distance as a measure gives it, and the distance."""
    if not isinstance(record, dict) or "distance" not in record:
        return False, None
    distance = record["distance"]
    if distance is None:
        return True, None
    if isinstance(distance, bool) or not isinstance(distance, (int, float)):
        return False, None
    if not math.isfinite(distance) or distance < 0:
        return False, None
    return True, float(distance)


def kept_distance(
    reference: np.ndarray,
    video: str | os.PathLike[str],
    measure: Callable[[], float | None],
) -> float | None:
    """The distance kept for ``reference`` and ``video``, else ``measure()``'s (then kept).

    Parameters
    ----------
    reference : numpy.ndarray
        The model's reference frame (its pixels name the entry).
    video : path-like
        The video (its bytes name the entry).
    measure : callable
        Measures the distance (:func:`~miketalk.track.identity.person_distance`; None: no
        face to compare) when none is kept.

    Returns
    -------
    float or None
        The distance, as ``measure`` gives it.
    """
    from miketalk.media.user_cache import cache_dir, read_record, write_record

    if cache_dir(KIND) is None:  # $MIKETALK_CACHE=off, or none can be made
        return measure()
    try:
        key = identity_key(reference, video)
    except OSError as err:  # the video cannot be read: measuring it says so
        log.debug("no identity entry for %s (%s)", video, err)
        return measure()
    found, distance = _kept(read_record(KIND, *key))
    if found:
        log.info("%s: its face's distance to the model's was kept from a run before", video)
        return distance
    distance = measure()
    write_record(KIND, {"distance": distance}, *key)
    return distance
