"""``python -m miketalk_lab.bench.colour_dub HOW ARGS...``: ``miketalk ARGS...`` with the
dubbed mouth's colour matched to its frames by ``HOW`` (``gain`` or ``offset``,
:mod:`miketalk.composite.colour`) instead of :data:`miketalk.defaults.BLEND_COLOUR`: the
held-out bench's switch (:mod:`miketalk_lab.bench.anyone` ``--colour``), so both ways are
measured on the same clips through the product's own command.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Switch the colour match for this process, then run the command line."""
    from miketalk import defaults
    from miketalk.cli import main as cli
    from miketalk.composite.colour import COLOUR_MATCHES

    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COLOUR_MATCHES:
        print(f"colour_dub: the first argument is one of {', '.join(COLOUR_MATCHES)}",
              file=sys.stderr)  # fmt: skip
        return 2
    defaults.BLEND_COLOUR = argv[0]
    return cli(argv[1:])


if __name__ == "__main__":
    sys.exit(main())
