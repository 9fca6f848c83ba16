"""Support for the Snakemake scripts in ``workflow/scripts``: logging and clean errors."""

from __future__ import annotations

import errno
import logging
import sys
import traceback
from collections.abc import Callable
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from miketalk.errors import MiketalkError


def run_stage(smk: Any, stage: Callable[[], object]) -> None:
    """Run one rule's work with its log file set up.

    Log records go to the rule's ``log`` file (and stderr). A
    :class:`MiketalkError` (a user mistake: bad config, missing file) is
    reported as one line and ends the job with exit status 1, and so is the machine's
    fault the command line reports in one line (a full disk, a worker process killed: the
    words of :func:`miketalk.cli.main`'s); any other error
    keeps its traceback, in the log. The work runs with one BLAS thread, as the command
    line's (:func:`miketalk.workers.one_blas_thread`).
    """
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if smk.log:
        handlers.append(logging.FileHandler(str(smk.log[0]), mode="w"))
    logging.basicConfig(
        level=logging.INFO,
        format="%(asctime)s %(name)s %(levelname)s: %(message)s",
        handlers=handlers,
        force=True,
    )
    log = logging.getLogger(f"miketalk.rule.{smk.rule}")
    from miketalk.workers import one_blas_thread

    try:
        with one_blas_thread():  # as the command line runs: OpenBLAS's threads only spin
            stage()
    except MiketalkError as err:
        log.error("%s", err)
        sys.exit(1)
    except BrokenProcessPool:
        log.error("a worker process died (killed when memory or disk ran out?)")
        sys.exit(1)
    except OSError as err:
        if err.errno not in (errno.ENOSPC, errno.EDQUOT):
            log.error("unexpected failure:\n%s", traceback.format_exc())
            raise
        log.error("no space left on the disk%s", f": {err.filename}" if err.filename else "")
        sys.exit(1)
    except Exception:
        log.error("unexpected failure:\n%s", traceback.format_exc())
        raise
