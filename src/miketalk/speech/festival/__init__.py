"""Festival as the speech back-end.

``backend``  :class:`FestivalBackend`: synthesis, re-synthesis, the retimed run
``run``      one run in plan mode, and Festival's process (deadline, exit status)
``output``   the files Festival reads and writes (phones, plans, waves, dictated ends)
"""

from miketalk.speech.festival.backend import FestivalBackend
from miketalk.speech.festival.run import APT_PACKAGES

__all__ = ["APT_PACKAGES", "FestivalBackend"]
