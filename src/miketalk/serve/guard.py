"""The page's security rules, kept for every request in one ASGI middleware.

- **Host check**: on a loopback address the ``Host`` header must name it (no DNS
  rebinding: a page of another site whose name now points at 127.0.0.1 gets 404).
- **Requests that change anything** (every method but ``GET`` and ``HEAD``) must carry the
  header ``X-Miketalk: 1`` (a custom header: another site cannot send it without a CORS
  preflight, which the server never grants), and, when the browser says where they come
  from (``Origin``, ``Sec-Fetch-Site``), come from the page's own origin; else 403.
- **Every answer** carries ``X-Content-Type-Options: nosniff``, a Content-Security-Policy
  of the page's own origin only with ``frame-ancestors 'none'`` (and ``X-Frame-Options:
  DENY``), ``Referrer-Policy: no-referrer`` and ``Cross-Origin-Resource-Policy:
  same-origin`` (another site cannot embed the page's videos or pictures either).
"""

from __future__ import annotations

import contextlib
import ipaddress

from starlette.datastructures import Headers
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from miketalk.serve.bodies import body_read, drain

#: The headers every answer carries.
SECURITY = {
    "x-content-type-options": "nosniff",
    "referrer-policy": "no-referrer",
    "x-frame-options": "DENY",
    "cross-origin-resource-policy": "same-origin",
    "content-security-policy": "default-src 'self'; img-src 'self'; media-src 'self' blob:; "
    "style-src 'self'; script-src 'self'; connect-src 'self'; object-src 'none'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'",
}
_RAW = [(k.encode("latin-1"), v.encode("latin-1")) for k, v in SECURITY.items()]
#: What a request from elsewhere is told.
NOT_FROM_PAGE = "refused: not from the page"


def allowed_hosts(host: str, port: int) -> frozenset[str] | None:
    """The ``Host`` headers the server answers when it listens on ``host``:``port`` (None:
    any, on an address that is not a loopback one)."""
    with contextlib.suppress(ValueError):
        if not ipaddress.ip_address(host).is_loopback:
            return None
    shown = f"[{host}]" if ":" in host else host
    names = {"127.0.0.1", "localhost", "[::1]", shown}
    return frozenset(f"{name}:{port}" for name in names)


def error(message: str, status: int, request: Request | None = None, **headers: str):
    """A JSON refusal (``{"error": message}``); the connection is closed after it when the
    request's body was not read."""
    more = {"cache-control": "no-store"} | headers
    if request is not None and not body_read(request):
        more["connection"] = "close"
    return JSONResponse({"error": message}, status, headers=more)


class Guard:
    """The middleware (see the module docstring).

    Parameters
    ----------
    app : ASGI app
        The routes.
    hosts : frozenset of str or None
        :func:`allowed_hosts`.
    stall : float
        Seconds a refused request's small body may stall while it is read.
    """

    def __init__(self, app: ASGIApp, hosts: frozenset[str] | None, stall: float) -> None:
        self.app, self.hosts, self.stall = app, hosts, stall

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def secured(message: Message) -> None:
            if message["type"] == "http.response.start":
                message["headers"] = [
                    *(h for h in message.get("headers", ()) if h[0].lower() not in SECURITY),
                    *_RAW,
                ]
            await send(message)

        headers = Headers(scope=scope)
        if self.hosts is not None and headers.get("host", "") not in self.hosts:
            request = Request(scope, receive)
            await drain(request, self.stall)
            await error("not found", 404, request)(scope, receive, secured)
            return
        if scope["method"] not in ("GET", "HEAD") and not self._from_page(headers):
            request = Request(scope, receive)
            await drain(request, self.stall)
            await error(NOT_FROM_PAGE, 403, request)(scope, receive, secured)
            return
        await self.app(scope, receive, secured)

    @staticmethod
    def _from_page(headers: Headers) -> bool:
        if headers.get("x-miketalk") != "1":
            return False
        origin = headers.get("origin")
        if origin is not None and origin != f"http://{headers.get('host', '')}":
            return False
        return headers.get("sec-fetch-site", "same-origin") in ("same-origin", "none")
