"""A build in a process of its own, that a cancel can stop without leaving anything behind.

:class:`BuildRun` starts ``python -m miketalk.serve.build FD`` in a new session (so a process
group of its own, with the build's workers and tools), hands it the build's arguments as JSON
on its standard input, and reads its reports as JSON lines on the pipe ``FD``: each stage as
:func:`~miketalk.building.from_video.build_model_from_video` reports it, then the end
(``done``, ``error`` with the library's one line, or ``cancelled``). A cancel sends SIGTERM to
the group: the child takes it as Ctrl-C (:func:`miketalk.console.handle_termination`), so the
build's clean-up runs (its work folder beside the model is removed; the model folder only
ever appears complete, by rename, at the end); a child that has not ended after
:data:`CANCEL_GRACE` seconds is killed, and what it left beside the model swept
(:func:`miketalk.api.sweep_build`).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from miketalk import api, defaults
from miketalk.api import BuildSettings, MiketalkError, list_model_files, sweep_build

log = logging.getLogger(__name__)

#: The stages :func:`~miketalk.building.from_video.build_model_from_video` reports, in order.
BUILD_STAGES = (
    "segment",
    "corpus",
    "visemes",
    "eigenlips",
    "flows (mixed)",
    f"flows ({defaults.BUILD_FLOW_STRATEGY})",
    "model",
)
#: Seconds a cancelled build has to clean up after SIGTERM before it is killed.
CANCEL_GRACE = 30.0
#: What the model's ``build/`` keeps of the page's build: its label.
LABEL_FILE = "serve.json"


class BuildRun:
    """A build in a child process (see the module docstring).

    Parameters
    ----------
    video : Path
        The video of the person.
    model_dir : Path
        The model folder to make (it appears only when the model is complete).
    script : mapping
        ``{"transcript": path}`` or ``{"subtitles": path}``.
    label : str
        The model's name on the page (kept in its ``build/serve.json``).
    options : mapping
        More of :class:`~miketalk.api.BuildSettings` (JSON values).
    workers : int
        Cores the build uses.
    """

    def __init__(
        self,
        video: Path,
        model_dir: Path,
        script: Mapping[str, Path],
        *,
        label: str,
        options: Mapping[str, Any],
        workers: int,
    ) -> None:
        self.model_dir = model_dir
        read_end, write_end = os.pipe()
        job = {
            "video": str(video), "model_dir": str(model_dir),
            "script": {k: str(v) for k, v in script.items()}, "label": label,
            "options": dict(options), "workers": workers,
        }  # fmt: skip
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "miketalk.serve.build", str(write_end)],
                stdin=subprocess.PIPE, pass_fds=(write_end,), start_new_session=True,
            )  # fmt: skip
        except BaseException:
            os.close(read_end)
            raise
        finally:
            os.close(write_end)
        self._pipe, self._buffer = read_end, b""
        try:
            self.process.stdin.write(json.dumps(job).encode("utf-8"))
            self.process.stdin.close()
        except OSError:  # it died at once: its end says why
            pass

    def messages(self, timeout: float) -> list[tuple]:
        """What the child reported within ``timeout`` seconds (empty: nothing yet), as tuples:
        ``("stage", name, seconds, peak_mb)``, ``("warning", line)``, ``("done", seconds by
        stage)``, ``("error", line)``, ``("cancelled",)``."""
        if self._pipe < 0:
            return []
        ready, _, _ = select.select([self._pipe], [], [], timeout)
        while ready:
            block = os.read(self._pipe, 1 << 16)
            if not block:
                os.close(self._pipe)
                self._pipe = -1
                break
            self._buffer += block
            ready, _, _ = select.select([self._pipe], [], [], 0)
        *lines, self._buffer = self._buffer.split(b"\n")
        out = []
        for line in lines:
            with contextlib.suppress(ValueError, TypeError):
                out.append(tuple(json.loads(line)))
        return out

    def alive(self) -> bool:
        """Whether the child still runs."""
        return self.process.poll() is None

    def cancel(self) -> None:
        """Stop the build (see the module docstring); returns when the child has ended."""
        self._signal(signal.SIGTERM)
        try:
            self.process.wait(CANCEL_GRACE)
        except subprocess.TimeoutExpired:
            log.warning("the build did not stop in %.0f s: killed", CANCEL_GRACE)
        self._signal(signal.SIGKILL)  # the child, and anything of its group still there
        self.process.wait()
        sweep_build(self.model_dir)

    def _signal(self, signum: int) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.process.pid, signum)

    def close(self) -> None:
        """Wait for the child and close the pipe."""
        self.process.wait()
        if self._pipe >= 0:
            os.close(self._pipe)
            self._pipe = -1


def _one_line(err: BaseException) -> str:
    from miketalk.serve.work import one_line

    return one_line(err)


def main(argv: list[str]) -> int:
    """The child: build what standard input says, report on the pipe ``argv[1]``: its
    stages, its warnings (the server logs each once and shows it on the page), its end."""
    logging.basicConfig(level=logging.WARNING, format="miketalk serve: build: %(message)s")
    from miketalk.console import handle_termination

    report = os.fdopen(int(argv[1]), "w", buffering=1, encoding="utf-8")

    def send(*message: object) -> None:
        with contextlib.suppress(OSError, ValueError):
            report.write(json.dumps(message) + "\n")

    class Reported(logging.Handler):  # a warning goes to the server, not to stderr
        def emit(self, record: logging.LogRecord) -> None:
            send("warning", " ".join(self.format(record).split()))

    warned = Reported(logging.WARNING)
    warned.addFilter(lambda r: r.levelno < logging.ERROR)
    root = logging.getLogger()
    for handler in root.handlers:
        handler.setLevel(logging.ERROR)
    root.addHandler(warned)

    with handle_termination():
        try:
            job = json.loads(sys.stdin.read())
            settings = BuildSettings(workers=job["workers"], **job["options"])
            built = api.build(
                job["video"], job["model_dir"], settings, **job["script"],
                report=lambda stage, took, peak: send("stage", stage, took, peak),
            )  # fmt: skip
            doc = {"label": job["label"], "built": time.strftime("%Y-%m-%d %H:%M:%S")}
            with contextlib.suppress(OSError):
                from miketalk.serve.work import write_text

                write_text(Path(job["model_dir"]) / "build" / LABEL_FILE, json.dumps(doc))
                list_model_files(job["model_dir"])  # named: one of the model's own files
            send("done", built.stage_seconds)
        except KeyboardInterrupt:
            send("cancelled")
            return 130
        except BaseException as err:  # every failure is one line on the page
            if not isinstance(err, MiketalkError):
                log.exception("the build failed")
            send("error", _one_line(err))
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
