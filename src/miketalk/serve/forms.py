"""A job the page asks for, checked before it is queued: its settings, its model, its files.

The page sends a job as JSON: the model by its id in the server's list, the uploads by the
ids :class:`~miketalk.serve.uploads.Uploads` gave them, the text as text, and choices from
closed lists (lip-sync model, voice). Anything else is refused in one line before a folder
is made; the library's checks before the work (:func:`miketalk.api.check`: the lip-sync model
against the model, a dub's model being a person's), the same as the command line's, are made
here too, so their line comes at once.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from miketalk import api
from miketalk.api import DubSettings, MiketalkError, SaySettings, SettingError
from miketalk.api.vocabulary import DEFAULT_VOICE, LIPSYNC_MODELS, VOICES
from miketalk.serve.catalog import Catalog, Entry
from miketalk.serve.config import MAX_TEXT_CHARS, MAX_TEXT_WORDS
from miketalk.serve.jobs import Board
from miketalk.serve.live import LIVE_FILE, LiveFile
from miketalk.serve.records import Job, plainly
from miketalk.serve.uploads import Upload, Uploads

#: The kinds of job the page can ask for.
KINDS = ("say", "dub", "build")
#: The longest name of a model built on the page, characters.
MAX_LABEL_CHARS = 80
#: A word, as the library counts them for its limit.
_WORDS = re.compile(r"[A-Za-z0-9']+")
#: What the page shows for the words of a recording or video given without them.
RECOGNIZED = "recognized from its speech"
#: What the page shows for the model of a dub given none: built from its video (and kept).
OWN_MODEL = "the video's own"
#: The page's name of each setting a job sets (:class:`~miketalk.errors.SettingError`'s names).
FIELDS = {"lipsync_model": "lipsync", "audio": "recording"}


def _text(body: Mapping[str, Any], key: str = "text", limit: int = MAX_TEXT_CHARS) -> str:
    value = body.get(key)
    if value is None:
        return ""
    if not isinstance(value, str):
        raise MiketalkError(f"the {key} must be text")
    if len(value) > limit:
        raise MiketalkError(f"the {key} is {len(value):,} characters long: at most {limit:,}")
    if key == "text" and (words := len(_WORDS.findall(value))) > MAX_TEXT_WORDS:
        raise MiketalkError(
            f"the text has {words:,} words: at most {MAX_TEXT_WORDS:,} (some 60 minutes of "
            "speech); split it"
        )
    return value.strip()


def _choice(body: Mapping[str, Any], key: str, choices: tuple[str, ...], default: str) -> str:
    value = body.get(key) or default
    if value not in choices:
        raise MiketalkError(f"{key} must be one of {', '.join(c for c in choices if c)}")
    return value


def _speech_settings(
    body: Mapping[str, Any], entry: Entry | None, *, recorded: bool, dub: bool
) -> dict[str, Any]:
    """The text, lip-sync model and voice of a say or dub, checked against the model by the
    library's own check (:func:`miketalk.api.check`), its settings named as the page names
    them (:data:`FIELDS`) and its paths as the page knows them; with no model (a dub's own,
    built from its video), checked by the library once it is built."""
    text = _text(body)
    if not recorded and not text:
        raise MiketalkError("no text: type what the face should say, or give a recording")
    lipsync = _choice(body, "lipsync", ("", *LIPSYNC_MODELS), "")
    voice = None if recorded else _choice(body, "voice", tuple(VOICES), DEFAULT_VOICE)
    chosen = None
    if entry is not None:
        options = {"model": entry.path, "lipsync_model": lipsync or None, "voice": voice}
        try:
            settings = (DubSettings if dub else SaySettings)(**options)
            chosen = api.check(settings, recorded=recorded, dub=dub)[1]
        except MiketalkError as err:  # named as the page knows them
            line = err.render(FIELDS) if isinstance(err, SettingError) else str(err)
            raise MiketalkError(plainly(line, [(str(entry.path), entry.label)])) from None
    return {"text": text or None, "lipsync": lipsync or None, "voice": voice, "chosen": chosen}


def make_job(body: object, *, board: Board, catalog: Catalog, uploads: Uploads) -> Job:
    """Check the page's request ``body`` and queue its job.

    Raises
    ------
    MiketalkError
        In one line: a malformed request, an unknown model or upload, a setting the model
        cannot take, no text.
    """
    if not isinstance(body, Mapping):
        raise MiketalkError("a job is a JSON object")
    kind = body.get("kind")
    if kind not in KINDS:
        raise MiketalkError(f"kind must be one of {', '.join(KINDS)}")
    if kind == "build":
        return _build(body, board=board, uploads=uploads)
    recorded = bool(body.get("audio"))
    own = kind == "dub" and not body.get("model")  # the video's own model (api.dub's, cached)
    entry = None if own else catalog.get(body.get("model"))
    settings = _speech_settings(body, entry, recorded=recorded, dub=kind == "dub")
    if kind == "dub" and not body.get("video"):
        raise MiketalkError("choose the video to dub")
    job = board.new_job(kind)
    try:
        audio = video = None
        if recorded:
            audio = _take(job, uploads, body["audio"], ("audio", "video"), "recording")
        if kind == "dub":
            video = _take(job, uploads, body["video"], ("video",), "video")
        job.params = {
            "model_dir": entry.path if entry else None, "text": settings["text"],
            "lipsync": settings["lipsync"], "voice": settings["voice"],
            "audio": audio.path if audio else None,
        } | ({"video": video.path} if video else {})  # fmt: skip
        chosen = settings["chosen"]
        job.shown = {
            "model": entry.label if entry else OWN_MODEL,
            "text": settings["text"],
            "words": RECOGNIZED if recorded and not settings["text"] else None,
            "recording": audio.name if audio else None,
            "video": video.name if video else None,
            "lipsync": settings["lipsync"]
            or f"the model's own{f' ({chosen.value})' if chosen else ''}",
            "voice": None if recorded else settings["voice"],
        }
        if entry is not None:
            job.aliases.append((str(entry.path), entry.label))
        if body.get("live"):  # played as it is made (miketalk.serve.live)
            job.live = LiveFile(job.folder / LIVE_FILE)
    except BaseException:
        shutil.rmtree(job.folder, ignore_errors=True)
        raise
    return board.submit(job)


def _build(body: Mapping[str, Any], *, board: Board, uploads: Uploads) -> Job:
    label = " ".join(_text(body, "name", limit=1000).split())[:MAX_LABEL_CHARS]
    if not body.get("video"):
        raise MiketalkError("choose the video of the person to build the face from")
    job = board.new_job("build")
    try:
        video = _take(job, uploads, body["video"], ("video",), "video")
        label = label or Path(video.name).stem or "a face"
        job.shown = {"name": label, "video": video.name}
        script = {}  # none: the video's words are recognized (api.build)
        if body.get("script"):
            given = uploads.take(body["script"], ("script",), job.folder, "script")
            kind = "subtitles" if given.path.suffix in (".srt", ".vtt") else "transcript"
            path = given.path.rename(given.path.with_name(kind + given.path.suffix))
            job.aliases.append((str(path), given.name))
            script, job.shown[kind] = {kind: path}, given.name
        else:
            job.shown["words"] = RECOGNIZED
        model_dir = board.config.models / job.id
        job.params = {"video": video.path, "script": script, "label": label,
                      "model_dir": model_dir}  # fmt: skip
        job.aliases.append((str(model_dir), f"the model {label}"))
    except BaseException:
        shutil.rmtree(job.folder, ignore_errors=True)
        raise
    return board.submit(job)


def _take(job: Job, uploads: Uploads, upload_id: object, kinds, stem: str) -> Upload:
    upload = uploads.take(upload_id, kinds, job.folder, stem)
    job.aliases.append((str(upload.path), upload.name))
    return upload
