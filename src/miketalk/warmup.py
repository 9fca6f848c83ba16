"""Load the morph's compiled kernels in a background thread, as early as a process can.

Importing numba and loading the morph's cached kernels takes about a second
(numba initialises its whole CPU target on the first call). ``miketalk say``
starts this before it reads its model, so that the load runs while Festival
speaks instead of after it. Only the standard library is imported here, so
starting it costs nothing.
"""

from __future__ import annotations

import threading

_lock = threading.Lock()
_thread: threading.Thread | None = None


def start() -> threading.Thread:
    """Start the warm-up thread once per process (later calls return the same thread)."""
    global _thread
    with _lock:
        if _thread is None:
            _thread = threading.Thread(target=_load, name="miketalk-warm-up", daemon=True)
            _thread.start()
        return _thread


def wait() -> None:
    """Block until the kernels are loaded (starting the load if it was not started)."""
    start().join()


def _load() -> None:
    try:
        import numpy as np

        from miketalk.morph import Morpher

        # numba specialises on array types, not sizes: a tiny pair of the types
        # every model uses (uint8 pixels, float32 flows) loads the same kernels
        image = np.zeros((4, 4, 3), np.uint8)
        flow = np.zeros((4, 4, 2), np.float32)
        Morpher(image, image, flow, flow).frame(0.5)
    except Exception:  # the same call fails again, with its message, where it is used
        pass
