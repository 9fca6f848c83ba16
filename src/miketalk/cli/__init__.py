"""The ``miketalk`` command line: ``say``, ``cues`` and ``phones``, one module each.

:func:`main` runs it (:mod:`~miketalk.cli.main`); :func:`build_parser` is its
parser (:mod:`~miketalk.cli.parser`).
"""

from miketalk.cli.main import main
from miketalk.cli.parser import build_parser

__all__ = ["build_parser", "main"]
