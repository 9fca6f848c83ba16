"""What every bench's command line shares: its parser, ``--limit``, and how an error ends it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from miketalk.errors import MiketalkError


def bench_parser(module: str, doc: str | None, *, limit_help: str) -> argparse.ArgumentParser:
    """The parser of ``python -m module``, described by the first line of its docstring.

    Parameters
    ----------
    module : str
        The bench's module name (``__name__``; ``__main__`` is resolved).
    doc : str or None
        Its docstring (``__doc__``).
    limit_help : str
        Help of the ``--limit`` option every bench has (how many clips it takes).
    """
    if module == "__main__":  # run as python -m: the module's own name is in its spec
        spec = getattr(sys.modules["__main__"], "__spec__", None)
        module = spec.name if spec is not None else module
    parser = argparse.ArgumentParser(
        prog=f"python -m {module}", description=(doc or module).splitlines()[0]
    )
    parser.add_argument("--limit", type=int, default=None, help=limit_help)
    return parser


def run_bench(
    parser: argparse.ArgumentParser,
    argv: Sequence[str] | None,
    work: Callable[[argparse.Namespace], str],
    *,
    check: Callable[[argparse.Namespace], str | None] | None = None,
) -> int:
    """Parse ``argv``, run ``work`` and print the summary it returns.

    A ``--limit`` under 1, or what ``check`` returns for the arguments, is a usage
    error (argparse's exit status 2); a :class:`MiketalkError` raised by ``work`` is
    printed on stderr as ``error: ...`` and gives 1; success gives 0.
    """
    args = parser.parse_args(argv)
    if args.limit is not None and args.limit < 1:
        parser.error("--limit must be at least 1")
    problem = check(args) if check is not None else None
    if problem:
        parser.error(problem)
    try:
        summary = work(args)
    except MiketalkError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(summary)
    return 0
