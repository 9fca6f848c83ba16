"""A video's registration to a model, kept for the next run: a second ``dub`` of the same
video with the same model neither tracks nor registers it again.

Registering a video to a face-crop model (:func:`~miketalk.composite.tracked.
tracked_background`: the face tracked in every frame, each crop registered by ECC, the
conform field, the blinks and each shot's light) is most of a ``dub``'s work: 10.5 s of
the 19 s of CPU a 10-s 720p dub took. What it makes is small (a transform a frame, the
field, a few median crops) and depends only on the video's bytes, the model's files, the
settings and the code. :func:`kept_background` keeps it in the user's cache
(:mod:`miketalk.media.user_cache`, kind :data:`KIND`) under a name made of all of them:

- the video's SHA-256 (its bytes, read each time: a file changed in place is another key);
- the model's manifest (every file's SHA-256: its reference, face mask, crop, stabilizer);
- whether the person was checked (an entry made under ``--force`` never serves a run that
  checks), the background's smoothing;
- the package's version and the SHA-256 of the source of what computes it (tracking,
  stabilizing, registration), and ffmpeg's path, size and time (its decoding).

A run that finds its entry plays the video with the kept registration, and says the same
warning the first run said of frames without a face; the output is the first run's, byte
for byte. Entries are written whole and then renamed, read with ``allow_pickle=False`` and
checked against the video's frame count; one that cannot be read is made again. Without a
cache (``$MIKETALK_CACHE=off``) or for a model without a manifest's checksums, everything
is done as before.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from miketalk import defaults
from miketalk.composite.background import Background
from miketalk.media.user_cache import ffmpeg_stamp, file_digest, source_digest

__all__ = ["KIND", "kept_background", "registration_key", "untracked_warning"]

log = logging.getLogger(__name__)

#: The kind of cache entry (:func:`~miketalk.media.user_cache.cache_dir`).
KIND = "registrations"

#: The entry's layout; a change makes every old entry another key.
FORMAT = 1

#: The product's modules whose source makes a registration (their bytes are in the key).
_MAKERS = ("track", "stabilize", "composite", "media/decode.py", "defaults.py")


def untracked_warning(source: str, left_out: tuple[str, ...], untracked: int, n: int) -> None:
    """Warn that ``untracked`` of ``n`` frames show no one frontal face (``left_out``: the
    tracker's failure ranges, as said)."""
    if not left_out:
        return
    listed = "; ".join(left_out[:6]) + ("; ..." if len(left_out) > 6 else "")
    log.warning(
        "%s: %d of its %d frames show no one frontal face and play without a new mouth (%s)",
        source, untracked, n, listed,
    )  # fmt: skip


def registration_key(
    model: Any, video: str | os.PathLike[str], *, check_person: bool
) -> list | None:
    """What names ``video``'s registration to ``model`` (see the module docstring); None
    when the model's manifest records no checksums (nothing to name it by)."""
    from miketalk import __version__

    manifest = getattr(model, "manifest", None)
    if not isinstance(manifest, dict) or not manifest.get("files"):
        return None
    model_digest = hashlib.sha256(
        json.dumps(manifest, sort_keys=True, separators=(",", ":")).encode("utf-8")
    ).hexdigest()
    return [
        FORMAT, __version__, source_digest(_MAKERS), ffmpeg_stamp(), file_digest(video),
        model_digest, bool(check_person), float(defaults.BACKGROUND_SMOOTH),
    ]  # fmt: skip


def _entry(key: list) -> Path | None:
    """The entry's file for ``key`` (None: no cache)."""
    from miketalk.media.user_cache import cache_dir, entry_name

    where = cache_dir(KIND)
    return None if where is None else where / f"{entry_name(*key)}.npz"


def read_kept(key: list, video: str | os.PathLike[str], source: str) -> Background | None:
    """The background kept for ``key``, its frames read from ``video`` when played (None:
    no entry, or one that cannot be read or does not fit the video)."""
    from miketalk.media.decode import video_info
    from miketalk.media.frame_source import played

    path = _entry(key)
    if path is None or not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as got:
            arrays = {name: got[name] for name in got.files}
        meta = json.loads(str(arrays.pop("meta")))
        if meta["key"] != json.loads(json.dumps(key)):
            return None
        n, fps = int(meta["frames"]), float(meta["fps"])
        transforms = arrays["transforms"]
        if transforms.shape != (n, 2, 3) or arrays["shown"].shape != (n,):
            return None
        width, height, _ = video_info(video)
        if [width, height] != meta["size"]:
            return None
        shots = {int(k): arrays[f"steady_shot_{k}"] for k in meta["shots"]}
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as err:
        log.debug("the kept registration %s was not read (%s): made again", path, err)
        return None
    frames, planes = played(video, count=n, fps=fps)
    shown = arrays["shown"].astype(bool)
    untracked_warning(source, tuple(meta["left_out"]), int((~shown).sum()), n)
    return Background(
        frames, transforms, arrays.get("field"), fps, tuple(meta["blinks"]), source,
        arrays.get("steady"), shown=shown, shot=arrays.get("shot"),
        steady_shots=shots if meta["has_shots"] else None, left_out=tuple(meta["left_out"]),
        i420=planes,
    )  # fmt: skip


def keep(key: list, background: Background, size: tuple[int, int]) -> bool:
    """Keep ``background``'s registration (not its frames) for ``key``, whole or not at all;
    whether it was kept (a cache that cannot be written is no error)."""
    from miketalk.media.atomic import write_bytes_atomic

    path = _entry(key)
    if path is None:
        return False
    shots = background.steady_shots or {}
    meta = {
        "key": key, "frames": len(background), "fps": background.fps,
        "blinks": [int(b) for b in background.blinks], "size": [int(size[0]), int(size[1])],
        "shots": sorted(int(k) for k in shots), "has_shots": background.steady_shots is not None,
        "left_out": list(background.left_out),
    }  # fmt: skip
    arrays: dict[str, np.ndarray] = {
        "meta": np.array(json.dumps(meta)),
        "transforms": np.asarray(background.transforms, np.float64),
        "shown": np.ones(len(background), bool) if background.shown is None else background.shown,
    }
    for name in ("field", "steady", "shot"):
        if (value := getattr(background, name)) is not None:
            arrays[name] = np.asarray(value)
    arrays |= {f"steady_shot_{k}": np.asarray(v) for k, v in shots.items()}
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    try:
        write_bytes_atomic(path, buffer.getvalue())
    except OSError as err:
        log.debug("the registration was not kept (%s)", err)
        return False
    return True


def kept_background(model: Any, video: str | os.PathLike[str], make, *, check_person: bool):
    """``video``'s background registered to ``model``: the one kept in the cache for them,
    else ``make()``'s (then kept).

    Parameters
    ----------
    model : miketalk.model.face.Model
    video : path-like
        The video (its bytes name the entry).
    make : callable
        Registers the video (tracks, checks, registers) when nothing is kept.
    check_person : bool
        Whether ``make`` checks that the video shows the model's person.
    """
    from miketalk.media.decode import video_info

    key = registration_key(model, video, check_person=check_person)
    if key is not None and _entry(key) is not None:
        found = read_kept(key, video, str(video))
        if found is not None:
            log.info("%s: its registration to the model was kept from a run before", video)
            return found
    background = make()
    if key is not None and isinstance(background, Background):
        width, height, _ = video_info(video)
        keep(key, background, (width, height))
    return background
