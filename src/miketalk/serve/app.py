"""The server: its state (:class:`App`) and the ASGI server that serves it (uvicorn).

:func:`make_server` binds the address first (so a port in use is one line before anything
starts) and hands the socket to uvicorn, with its pure-Python HTTP parser (h11), no access
log, no proxy headers trusted and no lifespan; :mod:`miketalk.serve.routes` holds the routes
and :mod:`miketalk.serve.guard` the security rules. :meth:`Server.serve_forever` runs the
event loop in the calling thread until :meth:`Server.shutdown` is called from another (the
command line's main thread waits for Ctrl-C or SIGTERM, stops the jobs, then the server).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import threading
from collections.abc import Iterator

import uvicorn

from miketalk.api import MiketalkError
from miketalk.serve.config import ServeConfig
from miketalk.serve.routes import asgi
from miketalk.serve.state import App

__all__ = ["App", "Server", "make_server"]

log = logging.getLogger(__name__)

#: Seconds open connections (a stream being played) get to end when the server stops.
STOP_GRACE = 2.0


class _Uvicorn(uvicorn.Server):
    """uvicorn's server without its own signal handlers: the command line's main thread
    has them (:func:`miketalk.console.handle_termination`)."""

    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield


class Server:
    """The bound socket, the :class:`App` and the uvicorn server over them.

    Attributes
    ----------
    server_address : tuple
        The address bound (``(host, port)``; port 0 asked: the port chosen).
    app : App
    """

    def __init__(self, config: ServeConfig, sock: socket.socket, app: App) -> None:
        self.socket, self.app = sock, app
        self.server_address = sock.getsockname()[:2]
        host, port = self.server_address
        settings = uvicorn.Config(
            asgi(app, host, port), http="h11", ws="none", lifespan="off", log_config=None,
            access_log=False, proxy_headers=False, server_header=False,
            timeout_graceful_shutdown=STOP_GRACE, timeout_keep_alive=5,
        )  # fmt: skip
        self._uvicorn = _Uvicorn(settings)
        self._serving, self._ended = threading.Event(), threading.Event()

    def serve_forever(self, poll_interval: float | None = None) -> None:
        """Serve until :meth:`shutdown` (``poll_interval``: kept for the standard library's
        signature; uvicorn looks every 0.1 s)."""
        self._serving.set()
        try:
            asyncio.run(self._uvicorn.serve(sockets=[self.socket]))
        finally:
            self._ended.set()

    def shutdown(self, timeout: float = 30.0) -> None:
        """Stop serving and wait (up to ``timeout`` s) until :meth:`serve_forever` returns."""
        self._uvicorn.should_exit = True
        if self._serving.is_set():
            self._ended.wait(timeout)

    def server_close(self) -> None:
        """Close the listening socket."""
        self.socket.close()


def make_server(config: ServeConfig) -> Server:
    """A server for ``config``, bound and ready for :meth:`Server.serve_forever` (port 0: a
    free one, ``server_address`` says which).

    Raises
    ------
    MiketalkError
        The address cannot be bound (in use, not this machine's).
    """
    family = socket.AF_INET6 if ":" in config.host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((config.host, config.port))
        sock.listen(128)
        sock.set_inheritable(False)
    except OSError as err:
        sock.close()
        raise MiketalkError(
            f"cannot listen on {config.host}:{config.port}: {err.strerror or err}"
        ) from None
    try:
        return Server(config, sock, App(config))
    except BaseException:
        sock.close()
        raise
