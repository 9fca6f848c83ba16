"""Request bodies, read as they come with a limit on how long one may stall.

uvicorn's HTTP parser (h11) hands a request's body over in pieces, whether the client sent
its length (``Content-Length``) or sent it chunked; :func:`pieces` yields them. A body that
stops coming for ``stall`` seconds raises :class:`Stalled` (the page answers 408 and closes
the connection), a client that leaves raises :class:`ClientLeft` (nobody to answer).
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Any

from starlette.requests import Request

from miketalk.api import MiketalkError

#: The most of a refused request's body read before answering (so the answer is not lost to
#: a reset); a longer body is left unread and its connection closed.
DRAIN_BYTES = 1 << 20


class Stalled(Exception):
    """The body stopped coming for ``seconds``."""

    def __init__(self, seconds: float) -> None:
        super().__init__(f"nothing received for {seconds:g} s")
        self.seconds = seconds


class ClientLeft(Exception):
    """The client closed the connection before its body was whole."""


def body_read(request: Request) -> bool:
    """Whether the body of ``request`` has been read to its end (else its connection is
    closed after the answer)."""
    return request.method in ("GET", "HEAD") or getattr(request.state, "body_read", False)


async def pieces(request: Request, stall: float) -> AsyncIterator[bytes]:
    """The pieces of the body of ``request`` as they come (see the module docstring)."""
    if body_read(request):
        return
    receive = request.receive
    while True:
        try:
            message = await asyncio.wait_for(receive(), stall)
        except TimeoutError:
            raise Stalled(stall) from None
        if message["type"] == "http.disconnect":
            raise ClientLeft
        if body := message.get("body", b""):
            yield body
        if not message.get("more_body", False):
            request.state.body_read = True
            return


async def read_json(request: Request, stall: float, limit: int, *, optional: bool = False) -> Any:
    """The body of ``request`` as JSON (None for an empty body when ``optional``).

    Raises
    ------
    MiketalkError
        A body over ``limit`` bytes, or not JSON.
    """
    raw = bytearray()
    async for piece in pieces(request, stall):
        raw += piece
        if len(raw) > limit:
            raise MiketalkError(f"the request is larger than {limit} bytes")
    if not raw and optional:
        return None
    try:
        return json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise MiketalkError("the request is not JSON") from None


async def drain(request: Request, stall: float) -> None:
    """Read what is left of a refused request's body when it is small (see
    :data:`DRAIN_BYTES`); a larger one, one that stalls or whose client left is left."""
    length = request.headers.get("content-length", "")
    if body_read(request) or not length.isdigit() or int(length) > DRAIN_BYTES:
        return
    try:
        async for _ in pieces(request, stall):
            pass
    except (Stalled, ClientLeft):
        pass
