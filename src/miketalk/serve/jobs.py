"""The background work: jobs, their folders, their two queues, and what the page sees of them.

Every job gets a new folder in the results named by the server
(``<results>/<YYYYmmdd-HHMMSS>-<kind>-<random>/``): its inputs are moved in, its outputs
written there, and ``job.json`` records it (when it is queued and when it ends), so that
a second tab never writes over a first's output and the results outlive the server.
``say`` and ``dub`` run one after the other in one worker thread (each takes seconds, and
two cores are better spent on one at a time); builds run one at a time in a child process
(:class:`miketalk.serve.work.BuildRun`), watched by a second thread, so a build and a
``say`` can run together and the page stays responsive. A queued job can be cancelled, and
so can a running build; a running ``say`` or ``dub`` finishes, unless the server stops: then
:class:`ServerStopping` is raised in the speech thread (:func:`interrupt`), its outputs'
temporary files are removed as on Ctrl-C, and the job ends ``interrupted``; so do the jobs
still queued.
"""

from __future__ import annotations

import json
import logging
import os
import queue
import secrets
import threading
import time
from pathlib import Path
from typing import Any

from miketalk.api import Cancelled, MiketalkError, OpenModels, Stream, load_engine
from miketalk.serve.build import BUILD_STAGES, BuildRun
from miketalk.serve.catalog import Catalog
from miketalk.serve.config import ServeConfig
from miketalk.serve.records import FINAL, RECORD, STOPPED, Job, earlier_jobs
from miketalk.serve.work import Outcome, one_line, speak, warnings_of, write_text

log = logging.getLogger(__name__)

#: The most warnings the page is shown of one job (all are logged).
MAX_WARNINGS = 20
#: Seconds :meth:`Board.close` waits for the speech thread once it has been interrupted.
SPEECH_STOP_SECONDS = 30.0  # (a say that is not live unwinds its stream's thread too: 10 s
# ran out at load 40 and left its temporary mp4)


class ServerStopping(KeyboardInterrupt):
    """Raised in the speech thread when the server stops while a ``say`` or ``dub`` runs:
    a KeyboardInterrupt, so that the library's clean-up runs as on Ctrl-C and no
    ``except Exception`` takes it for a failure."""


def interrupt(thread: threading.Thread) -> None:
    """Raise :class:`ServerStopping` in ``thread`` at its next Python instruction.

    CPython's ``PyThreadState_SetAsyncExc``: the thread is stopped wherever it runs
    Python (between two frames of a render, in Festival's wait, in a registration), and
    at once when it returns from C (a frame written to ffmpeg).
    """
    import ctypes

    if thread.ident is not None and thread.is_alive():
        ctypes.pythonapi.PyThreadState_SetAsyncExc(
            ctypes.c_ulong(thread.ident), ctypes.py_object(ServerStopping)
        )


class Board:
    """The jobs: made, queued, run, cancelled, listed (see the module docstring).

    Parameters
    ----------
    config : ServeConfig
    catalog : Catalog
        The models (a build's new model is looked up there when it is done).
    """

    def __init__(self, config: ServeConfig, catalog: Catalog) -> None:
        self.config = config
        self.catalog = catalog
        self._lock = threading.RLock()
        self._jobs: dict[str, Job] = {}
        self._speech: queue.Queue[Job | None] = queue.Queue()
        self._builds: queue.Queue[Job | None] = queue.Queue()
        self._closing = threading.Event()
        config.results.mkdir(parents=True, exist_ok=True)
        config.models.mkdir(parents=True, exist_ok=True)
        self._load_history()
        self._threads = [
            threading.Thread(target=self._speech_loop, name="miketalk-speech", daemon=True),
            threading.Thread(target=self._build_loop, name="miketalk-build", daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    # -- making and finding jobs

    def new_job(self, kind: str) -> Job:
        """A job of ``kind`` with a new folder of its own (not yet queued)."""
        for _ in range(100):
            stamp = time.strftime("%Y%m%d-%H%M%S")
            job_id = f"{stamp}-{kind}-{secrets.token_hex(3)}"
            folder = self.config.results / job_id
            try:
                folder.mkdir()
            except FileExistsError:
                continue
            job = Job(job_id, kind, folder)
            job.aliases.append((str(folder) + os.sep, ""))
            return job
        raise MiketalkError(f"cannot make a new folder in {self.config.results}")

    def submit(self, job: Job) -> Job:
        """Queue ``job`` (its record is written now)."""
        with self._lock:
            self._jobs[job.id] = job
            self._save(job)
        (self._builds if job.kind == "build" else self._speech).put(job)
        return job

    def get(self, job_id: object) -> Job:
        """The job called ``job_id``.

        Raises
        ------
        MiketalkError
            No such job.
        """
        with self._lock:
            job = self._jobs.get(job_id) if isinstance(job_id, str) else None
        if job is None:
            raise MiketalkError("no such job")
        return job

    def public(self, job_id: object) -> dict[str, Any]:
        """What the page sees of one job."""
        job = self.get(job_id)
        with self._lock:
            self._number_queues()
            return job.public()

    def listing(self) -> list[dict[str, Any]]:
        """Every job, the newest first."""
        with self._lock:
            self._number_queues()
            return [j.public() for j in sorted(self._jobs.values(), key=lambda j: -j.created)]

    def _number_queues(self) -> None:
        """Each queued job's place in its queue (1: the next to start), builds apart."""
        for builds in (False, True):
            waiting = [j for j in self._jobs.values()
                       if j.status == "queued" and (j.kind == "build") == builds]  # fmt: skip
            for place, job in enumerate(sorted(waiting, key=lambda j: j.created), 1):
                job.position = place

    def cancel(self, job_id: object) -> dict[str, Any]:
        """Cancel a queued job, stop a running live ``say`` or ``dub`` (its stream cancelled:
        the work and its processes end at once), or a running build (its thread terminates
        the child).

        Raises
        ------
        MiketalkError
            A job that has ended, or a ``say`` or ``dub`` running that is not live.
        """
        job = self.get(job_id)
        with self._lock:
            if job.status == "queued":
                if job.live is not None:
                    job.live.ended = True  # its followers end: nothing will come
                self._end(job, "cancelled", "cancelled before it started")
            elif job.status == "running" and job.kind == "build":
                job.cancel_asked = True
                job.stage = "cancelling"
            elif job.status == "running" and job.live is not None:
                if not job.cancel_asked:
                    job.cancel_asked, job.stop_asked = True, time.monotonic()
                    job.stage = "stopping"
                    if job.stream is not None:
                        job.stream.cancel()
            elif job.status == "running":
                raise MiketalkError(f"a {job.kind} cannot be stopped once it runs; it will end")
            else:
                raise MiketalkError(f"the job has ended ({job.status})")
            return job.public()

    def close(self) -> None:
        """Stop the threads: a running build is cancelled (and waited for), a running
        ``say`` or ``dub`` interrupted (:func:`interrupt`), the queued jobs not started."""
        with self._lock:
            self._closing.set()  # under the lock: no job starts after this
            for job in self._jobs.values():
                if job.kind == "build" and job.status == "running":
                    job.cancel_asked = True
            speaking = [
                j for j in self._jobs.values() if j.kind != "build" and j.status == "running"
            ]
            for job in speaking:
                if job.live is not None:
                    job.live.ended = True
                if job.stream is not None:
                    job.stream.cancel()  # the work and its processes end at once
        self._speech.put(None)
        self._builds.put(None)
        speech = self._threads[0]
        if speaking:
            speech.join(timeout=0.5 if speaking[0].stream is not None else 0)
            interrupt(speech)
            speech.join(timeout=SPEECH_STOP_SECONDS)
            if speech.is_alive():
                log.warning("the running job did not stop within %g s", SPEECH_STOP_SECONDS)
        for thread in self._threads:
            thread.join(timeout=60)

    # -- the two workers

    def _start(self, job: Job, stage: str) -> bool:
        with self._lock:
            if job.status != "queued":
                return False
            if self._closing.is_set():
                self._end(job, "interrupted", STOPPED)
                return False
            job.status, job.started, job.stage = "running", time.time(), stage
            return True

    def _end(self, job: Job, status: str, message: str | None = None, outcome=None) -> None:
        with self._lock:
            job.status, job.finished, job.message = status, time.time(), message
            job.stage = None
            if outcome is not None:
                job.result, job.files = outcome.result, outcome.files
            self._save(job)

    def _fail(self, job: Job, err: BaseException) -> None:
        if not isinstance(err, MiketalkError):
            log.error("job %s failed", job.id, exc_info=err)
        else:
            log.info("job %s: %s", job.id, err)
        self._end(job, "failed", job.plainly(one_line(err)))

    def _speech_loop(self) -> None:
        load_engine()  # the first job starts warm

        warm = OpenModels()
        job: Job | None = None
        try:
            while (job := self._speech.get()) is not None:
                if not self._start(job, "dubbing" if job.kind == "dub" else "speaking"):
                    continue
                try:
                    with warnings_of(lambda line, job=job: self.warn(job, line, logged=True)):
                        outcome = self._speak(job, warm)
                except ServerStopping:
                    self._end(job, "interrupted", STOPPED)
                    return
                except Cancelled:
                    with self._lock:
                        if job.stop_asked is not None:
                            job.stopped_in = round(time.monotonic() - job.stop_asked, 3)
                    if job.cancel_asked:
                        self._end(job, "cancelled", "stopped: nothing of it was kept")
                    else:
                        self._end(job, "interrupted", STOPPED)
                except Exception as err:
                    if self._closing.is_set():  # e.g. its ffmpeg killed by the stopping signal
                        self._end(job, "interrupted", STOPPED)
                    else:
                        self._fail(job, err)
                else:
                    self._end(job, "done", outcome=outcome)
        except ServerStopping:  # landed just before or after a job's work
            if job is not None and job.status not in FINAL:
                self._end(job, "interrupted", STOPPED)
        finally:
            warm.close()

    def _speak(self, job: Job, warm: OpenModels) -> Outcome:
        """The work of a ``say`` or ``dub``: live, its stream kept on the job while it runs
        (a Stop cancels it), or written to its mp4 (:func:`~miketalk.serve.work.speak`)."""
        if job.live is None:
            return speak(job.folder, **job.params, warm=warm)

        def started(stream: Stream) -> None:
            with self._lock:
                job.stream = stream
                if job.cancel_asked or self._closing.is_set():
                    stream.cancel()

        try:
            return speak(job.folder, **job.params, warm=warm, live=job.live, started=started)
        finally:
            with self._lock:
                job.stream = None
                job.live.ended = True

    def _build_loop(self) -> None:
        while (job := self._builds.get()) is not None:
            if not self._start(job, "checking the video"):
                continue
            try:
                self._build(job)
            except Exception as err:
                self._fail(job, err)

    def _build(self, job: Job) -> None:
        params = job.params
        run = BuildRun(
            params["video"], params["model_dir"], params["script"], label=params["label"],
            options=self.config.build_options, workers=self.config.workers,
        )  # fmt: skip
        ended: tuple | None = None
        try:
            while ended is None:
                alive = run.alive()  # before reading: a child that has ended has said all
                for message in run.messages(0.2 if alive else 0):
                    if message[0] == "stage":
                        self._stage_done(job, message[1], message[2])
                    elif message[0] == "warning":
                        self.warn(job, message[1])
                    else:
                        ended = message
                if ended is None and not alive:
                    ended = ("died",)
                with self._lock:
                    cancel = job.cancel_asked and ended is None
                if cancel:
                    run.cancel()
                    ended = ("cancelled",)
        finally:
            run.close()
        self._build_ended(job, ended)

    def warn(self, job: Job, line: str, *, logged: bool = False) -> None:
        """A warning of ``job``'s work, shown on the page (its first :data:`MAX_WARNINGS`)
        and logged once (here, unless it was ``logged`` where it was said)."""
        line = job.plainly(str(line))
        if not logged:
            log.warning("job %s: %s", job.id, line)
        with self._lock:
            if len(job.warnings) < MAX_WARNINGS:
                job.warnings.append(line)

    def _stage_done(self, job: Job, name: str, seconds: float) -> None:
        with self._lock:
            job.stages.append({"name": name, "seconds": round(seconds, 1)})
            later = [s for s in BUILD_STAGES if s not in {d["name"] for d in job.stages}]
            job.stage = "cancelling" if job.cancel_asked else (later[0] if later else "finishing")

    def _build_ended(self, job: Job, ended: tuple) -> None:
        model_dir: Path = job.params["model_dir"]
        if ended[0] == "done":
            entry = next((e for e in self.catalog.entries() if e.path == model_dir), None)
            result = {
                "model": entry.id if entry else None,
                "label": job.params["label"],
                "seconds": round(sum(ended[1].values()), 1),
            }
            self._end(job, "done", outcome=Outcome(result))
        elif ended[0] == "cancelled":
            self._end(job, "cancelled", "cancelled: no model was written")
        elif ended[0] == "error":
            self._end(job, "failed", job.plainly(ended[1]))
        else:
            log.error("the build of job %s died without a word", job.id)
            self._end(
                job, "failed", "the build's process died (killed when memory ran out?); "
                "no model was written",
            )  # fmt: skip

    # -- records

    def _save(self, job: Job) -> None:
        doc = job.public() | {
            "files": {name: path.name for name, path in job.files.items()},
            "params": {
                k: str(v) for k, v in job.params.items() if k in ("model_dir",) and v is not None
            },  # none: a dub's own
        }
        try:
            write_text(job.folder / RECORD, json.dumps(doc, indent=1))
        except OSError as err:
            log.warning("cannot record job %s: %s", job.id, err)

    def _load_history(self) -> None:
        """The jobs of earlier runs of the server, from their records."""
        for job in earlier_jobs(self.config.results):
            self._jobs[job.id] = job
