"""The ``miketalk`` command line: ``say``, ``cues`` and ``phones``.

Every user mistake (a bad setting, an output that cannot be written, a text
Festival cannot read, a broken model, an output miketalk did not write) is one line on
stderr and exit status 2,
found before the work starts where it can be. stdout carries only the result
(:mod:`miketalk.console`); ``-v`` logs progress and timings on stderr.
SIGTERM and SIGHUP stop a run as Ctrl-C does, and leave nothing behind; run as the
command (no ``argv`` given), a run so stopped then ends at once (``os._exit``, its
clean-up done), instead of waiting for the interpreter to free its memory (the
aligner's decoders: most of a second on a busy machine); so does every ``say``
(:data:`ENDS_AT_ONCE`). A full disk
or a worker process killed under it (by the kernel, when memory runs out) is one line and
exit status 1: not the user's mistake, but not a traceback either; outputs are written
atomically, so nothing half-written is left.
"""

from __future__ import annotations

import errno
import logging
import sys
from collections.abc import Sequence
from concurrent.futures.process import BrokenProcessPool

from miketalk.api import MachineFailure, MiketalkError, SettingError
from miketalk.cli.parser import build_parser
from miketalk.console import handle_termination, native_output_logged


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; user mistakes print one clear line and exit with status 2.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (default: the command line's, and a run stopped by a signal, or
        any run of :data:`ENDS_AT_ONCE`, ends the process at once: see the module
        docstring).

    Returns
    -------
    int
        The exit status: 0, 1 (the machine), 2 (a mistake), 128 + the signal.
    """
    code = _main(argv)
    if argv is None and (code > 128 or _ran[0] in ENDS_AT_ONCE):
        _end_now(code)
    return code


#: The commands that, run as the command, end at once (:func:`_end_now`) however they end:
#: when they return, their files are closed and their child processes reaped, and the
#: interpreter's own teardown (every module and array freed: some 30 ms of s1's 10-word
#: ``say``, whose whole command takes a second) would only delay the exit.
ENDS_AT_ONCE = frozenset({"say"})

_ran: list[str | None] = [None]  # the command :func:`_main` ran


def _end_now(code: int) -> None:
    """End the process with ``code`` now: its output flushed, nothing else run."""
    import contextlib
    import os

    with contextlib.suppress(Exception):
        logging.shutdown()
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(code)


def _main(argv: Sequence[str] | None) -> int:
    """:func:`main` but for its end."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _ran[0] = getattr(args, "command", None)
    if hasattr(args, "voice"):
        args.voice_given = args.voice is not None
        args.voice = args.voice or "kal"
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="miketalk: %(levelname)s: %(message)s",
    )
    if args.verbose:
        logging.getLogger("miketalk").setLevel(logging.INFO)
    from miketalk.workers import one_blas_thread

    with handle_termination():
        with native_output_logged() as out, one_blas_thread():
            args.out = out
            code, line = _outcome(args)
        # after the relay of native output has ended: the libraries' lines come first
        if line:
            print(line, file=sys.stderr)
        return code


def _outcome(args) -> tuple[int, str | None]:
    """Run the command of ``args``: its exit status, and the one line that ends it."""
    try:
        return args.func(args), None
    except MachineFailure as err:
        return 1, f"miketalk: error: {err}"
    except MemoryError:
        return 1, "miketalk: error: memory ran out; the output was not written"
    except SettingError as err:
        return 2, f"miketalk: error: {err.render(flag)}"
    except MiketalkError as err:
        return 2, f"miketalk: error: {err}"
    except KeyboardInterrupt as err:
        signum = getattr(err, "signum", 2)
        return 128 + signum, f"miketalk: {'interrupted' if signum == 2 else 'terminated'}"
    except BrokenProcessPool:
        return 1, (
            "miketalk: error: a worker process died (killed when memory or disk "
            "ran out?); the output was not written"
        )
    except BrokenPipeError:
        # the reader went away (e.g. `| head`): stop quietly
        import contextlib
        import io
        import os

        with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation):
            os.dup2(os.open(os.devnull, os.O_WRONLY), args.out.fileno())
        return 0, None
    except OSError as err:
        where = f": {err.filename}" if err.filename else ""
        if err.errno in (errno.ENOSPC, errno.EDQUOT):
            return 1, f"miketalk: error: no space left on the disk{where}"
        # the machine's doing or another program's (a file removed under a running
        # build): one line, the details with -v
        if args.verbose:
            import traceback

            traceback.print_exception(err, file=sys.stderr)
        return 1, (
            f"miketalk: error: {err.strerror or err}{where} (removed or changed while "
            "miketalk ran?); the output was not written"
        )


#: The settings whose flag is not their name (:func:`flag`).
FLAGS = {"overwrite": "--force"}


def flag(setting: str) -> str:
    """The option that sets ``setting`` (:class:`~miketalk.errors.SettingError`'s names):
    its name with dashes, ``--max-px-per-frame``, but for :data:`FLAGS`."""
    return FLAGS.get(setting, "--" + setting.replace("_", "-"))
