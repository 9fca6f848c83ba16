"""``python -m miketalk_lab.bench.colour_dub HOW ARGS...``: ``miketalk ARGS...`` with the
dubbed mouth's colour matched by ``HOW`` instead of the defaults: ``HOW`` is a compositor's
match (``offset``, ``gain`` or ``lips``, :mod:`miketalk.composite.colour`, for
:data:`miketalk.defaults.BLEND_COLOUR`), ``patches=LIGHT`` (``border`` or ``session``,
:mod:`miketalk.draw.trained.light`, for :data:`miketalk.defaults.PATCH_LIGHT`) or
``visemes=LIGHT`` (``built`` or ``session``, for :data:`miketalk.defaults.VISEME_LIGHT`),
or several joined by ``+`` (``lips+patches=session+visemes=built``): the held-out bench's
switch (:mod:`miketalk_lab.bench.anyone` ``--colour``, ``--patch-light`` and
``--viseme-light``), so both ways are measured on the same clips through the product's own
command.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

#: The prefix of a ``HOW`` part naming the trained face's patches' light.
PATCHES = "patches="
#: The prefix of a ``HOW`` part naming the viseme images' light.
VISEMES = "visemes="


def switches(how: str) -> dict[str, str]:
    """``HOW``'s settings of :mod:`miketalk.defaults` (name: value).

    Raises
    ------
    ValueError
        When a part of ``how`` is neither a colour match nor ``patches=LIGHT``.
    """
    from miketalk.composite.colour import COLOUR_MATCHES
    from miketalk.draw.trained.light import PATCH_LIGHTS, VISEME_LIGHTS

    named = {PATCHES + light: ("PATCH_LIGHT", light) for light in PATCH_LIGHTS}
    named |= {VISEMES + light: ("VISEME_LIGHT", light) for light in VISEME_LIGHTS}
    named |= {match: ("BLEND_COLOUR", match) for match in COLOUR_MATCHES}
    out = {}
    for part in how.split("+"):
        if part not in named:
            raise ValueError(f"{part!r} is none of {', '.join(named)}")
        out[named[part][0]] = named[part][1]
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Switch the colour match for this process, then run the command line."""
    from miketalk import defaults
    from miketalk.cli import main as cli

    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        settings = switches(argv[0]) if argv else None
    except ValueError as err:
        print(f"colour_dub: {err}", file=sys.stderr)
        return 2
    if not settings:
        print("colour_dub: the first argument says how (a colour match, patches=LIGHT or "
              "visemes=LIGHT)",
              file=sys.stderr)  # fmt: skip
        return 2
    for name, value in settings.items():
        setattr(defaults, name, value)
    return cli(argv[1:])


if __name__ == "__main__":
    sys.exit(main())
