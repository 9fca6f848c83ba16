"""A job's record: what it is, what the page sees of it, and its ``job.json``.

Every job gets a new folder in the results named by the server, and ``job.json`` there
records it (when it is queued and when it ends), so that the results outlive the server:
:func:`earlier_jobs` reads them back when it starts again.
"""

from __future__ import annotations

import json
import os
import re
import time
import unicodedata
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from miketalk.serve.build import BUILD_STAGES

#: The file in a job's folder that records it.
RECORD = "job.json"
#: A job's statuses; the last four are final.
STATUSES = ("queued", "running", "done", "failed", "cancelled", "interrupted")
FINAL = frozenset(STATUSES[2:])
#: What the page is told of a job the server's stop ended.
STOPPED = "the server stopped before this job ended"


@dataclass
class Job:
    """One piece of work the page asked for.

    Attributes
    ----------
    id, kind : str
        Its id (also its folder's name) and what it does: ``say``, ``dub`` or ``build``.
    folder : Path
        Its own folder in the results.
    params : dict
        What the work takes (paths included; never sent to the page).
    shown : dict
        What the page shows of its inputs (names as they were uploaded, the text, the model).
    aliases : list of (str, str)
        Server paths and the names the page knows them by (for messages).
    """

    id: str
    kind: str
    folder: Path
    params: dict[str, Any] = field(default_factory=dict)
    shown: dict[str, Any] = field(default_factory=dict)
    aliases: list[tuple[str, str]] = field(default_factory=list)
    status: str = "queued"
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    stage: str | None = None
    stages: list[dict[str, Any]] = field(default_factory=list)
    message: str | None = None
    result: dict[str, Any] | None = None
    files: dict[str, Path] = field(default_factory=dict)
    cancel_asked: bool = False
    warnings: list[str] = field(default_factory=list)
    position: int | None = None
    live: Any = field(default=None, repr=False)  # LiveFile: its stream as it is written
    stream: Any = field(default=None, repr=False)  # the library's Stream, while it runs
    stop_asked: float | None = None  # time.monotonic() of the Stop
    stopped_in: float | None = None  # seconds from the Stop to the work's end

    def public(self) -> dict[str, Any]:
        """What the page sees: no server path."""
        end = self.finished or time.time()
        return {
            "id": self.id,
            "kind": self.kind,
            "status": self.status,
            "created": self.created,
            "started": self.started,
            "finished": self.finished,
            "elapsed": round(end - self.started, 2) if self.started else None,
            "stage": self.stage,
            "stages": list(self.stages),
            "all_stages": list(BUILD_STAGES) if self.kind == "build" else [],
            "progress": len(self.stages) / len(BUILD_STAGES) if self.kind == "build" else None,
            "message": self.message,
            "result": self.result,
            "inputs": dict(self.shown),
            "files": {name: f"/files/{self.id}/{name}" for name in self.files},
            "downloads": {
                name: download_name(self.id, name, self.shown.get("text")) for name in self.files
            },
            "warnings": list(self.warnings),
            "position": self.position if self.status == "queued" else None,
            "live": f"/api/jobs/{self.id}/live" if self.live is not None else None,
            "stopped_in": self.stopped_in,
            "cancellable": self.status == "queued"
            or (self.status == "running" and (self.kind == "build" or self.live is not None)),
        }

    def plainly(self, line: str) -> str:
        """``line`` with the server's paths named as the page knows them."""
        return plainly(line, self.aliases)


def plainly(line: str, aliases: list[tuple[str, str]]) -> str:
    """``line`` with each path of ``aliases`` (path, name) named as the page knows it: the
    whole path, then its file's own name where the line names it alone (``video.mp4``, a
    name the server gave an upload, is the name the upload came with)."""
    for path, name in sorted(aliases, key=lambda a: -len(a[0])):
        line = line.replace(path, name)
    for path, name in aliases:
        base = os.path.basename(path)
        if base and name and "." in base:
            line = re.sub(rf"(?<![\w/.-]){re.escape(base)}(?![\w-])", lambda _, n=name: n, line)
    return line


def download_name(job_id: str, name: str, text: str | None = None) -> str:
    """What a job's file is saved as: the job's id, the first words of its text, and what
    the file is (``20261129-110000-say-a1b2c3-bin-blue-at-f-two.mp4``, its cues
    ``...-cues.json``; the mp4 and its timeline keep the job's kind alone)."""
    stem, dot, suffix = name.rpartition(".")
    words = unicodedata.normalize("NFKD", text or "").encode("ascii", "ignore").decode()
    slug = "-".join(re.sub(r"[^a-z0-9]+", " ", words.lower()).split()[:6])[:48].strip("-")
    what = "" if stem in ("say", "dub") else f"-{stem}"
    return f"{job_id}{'-' + slug if slug else ''}{what}{dot}{suffix}"


def earlier_jobs(results: Path) -> Iterator[Job]:
    """The jobs of earlier runs of the server, from their records in ``results``."""
    try:
        folders = sorted(p for p in results.iterdir() if p.is_dir())
    except OSError:
        return
    for folder in folders:
        try:
            doc = json.loads((folder / RECORD).read_text(encoding="utf-8"))
            job = Job(doc["id"], doc["kind"], folder, shown=dict(doc.get("inputs") or {}))
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if job.id != folder.name:
            continue
        job.status = doc.get("status") if doc.get("status") in FINAL else "interrupted"
        job.created = float(doc.get("created") or os.path.getmtime(folder))
        job.started, job.finished = doc.get("started"), doc.get("finished")
        job.stages = list(doc.get("stages") or [])
        job.result = doc.get("result")
        job.message = doc.get("message")
        if job.status == "interrupted":
            job.message = STOPPED
            job.finished = job.started
        files = doc.get("files") or {}
        job.files = {
            name: folder / name
            for name, stored in files.items()
            if name == stored and (folder / name).is_file()
        }
        yield job
