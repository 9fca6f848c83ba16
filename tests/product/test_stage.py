"""A workflow stage's end (miketalk.stage.run_stage): a user mistake and the machine's faults
the command line says in one line are one line in the rule's log too, not a traceback."""

from __future__ import annotations

import errno
from concurrent.futures.process import BrokenProcessPool
from types import SimpleNamespace

import pytest

from miketalk.errors import MiketalkError
from miketalk.stage import run_stage


def _raise(err: BaseException):
    def stage() -> None:
        raise err

    return stage


@pytest.mark.parametrize(
    ("err", "line"),
    [
        (MiketalkError("clip x: media file not found"), "clip x: media file not found"),
        (BrokenProcessPool("gone"), "a worker process died (killed when memory or disk ran out?)"),
        (
            OSError(errno.ENOSPC, "No space left on device", "results/flows/a.exr"),
            "no space left on the disk: results/flows/a.exr",
        ),
    ],
    ids=["mistake", "worker-killed", "disk-full"],
)
def test_a_stage_ends_in_one_line_for_a_mistake_or_the_machine(tmp_path, err, line) -> None:
    log = tmp_path / "rule.log"
    with pytest.raises(SystemExit) as ended:
        run_stage(SimpleNamespace(log=[str(log)], rule="flows"), _raise(err))
    assert ended.value.code == 1
    said = log.read_text()
    assert said.rstrip().endswith(f"miketalk.rule.flows ERROR: {line}")
    assert "Traceback" not in said and len(said.strip().splitlines()) == 1


def test_any_other_failure_keeps_its_traceback_in_the_log(tmp_path) -> None:
    log = tmp_path / "rule.log"
    err = OSError(errno.EACCES, "Permission denied", "results/x")
    with pytest.raises(OSError):
        run_stage(SimpleNamespace(log=[str(log)], rule="flows"), _raise(err))
    assert "unexpected failure" in log.read_text() and "Traceback" in log.read_text()
