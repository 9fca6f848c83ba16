"""The HTTP side: one static page, JSON endpoints, the files jobs made.

Routes (``GET`` unless said)::

    /                               the page (static/page.html, page.js, page.css)
    /api/config                     the upload limit, voices, lip-sync models, build stages
    /api/models                     the models (ids, names, what each can do)
    /api/models/<id>/image          a picture of a model's face
    POST /api/upload?kind=K         a file as the raw body (K: video, audio, script) -> its id
    POST /api/jobs                  a job as JSON (say, dub, build) -> the job
    /api/jobs, /api/jobs/<id>       the jobs, one job
    POST /api/jobs/<id>/cancel      cancel a queued job or a running build
    /files/<job>/<name>             a file the job made (byte ranges, for the video)

A ``POST`` must carry the header ``X-Miketalk: 1`` and, with an ``Origin``, come from the
page's own origin: another web site open in the same browser cannot send one without a
CORS preflight, which the server never grants. On a loopback address the ``Host`` header
must name it too (no DNS rebinding). A mistake is ``{"error": "<one line>"}`` with status
400 (413 for an upload over the limit); anything else is logged with its traceback and the
page gets one line. A request whose body stops coming for :attr:`Handler.timeout` seconds
gets 408 and its connection closed (one warning line, its thread let go); a client that
leaves mid-request is let go without a word.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import re
import socket
import socketserver
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, unquote, urlsplit

from miketalk import __version__
from miketalk.api import MiketalkError
from miketalk.api.vocabulary import DEFAULT_VOICE, LIPSYNC_MODELS, VOICES
from miketalk.serve.build import BUILD_STAGES
from miketalk.serve.catalog import Catalog
from miketalk.serve.config import MAX_JSON_BYTES, ServeConfig
from miketalk.serve.forms import make_job
from miketalk.serve.jobs import Board
from miketalk.serve.uploads import UploadRefused, Uploads

log = logging.getLogger(__name__)

#: The page's files and their types.
STATIC = {
    "page.html": "text/html; charset=utf-8",
    "page.js": "text/javascript; charset=utf-8",
    "page.css": "text/css; charset=utf-8",
    "icon.svg": "image/svg+xml",
}
#: Types of the files jobs make.
TYPES = {
    ".mp4": "video/mp4",
    ".json": "application/json",
    ".tsv": "text/tab-separated-values; charset=utf-8",
    ".png": "image/png",
}
_SECURITY = {
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
    "Content-Security-Policy": "default-src 'self'; img-src 'self'; media-src 'self'; "
    "style-src 'self'; script-src 'self'; connect-src 'self'; frame-ancestors 'none'",
}
_RANGE = re.compile(r"bytes=(\d*)-(\d*)")
_INTERNAL = "something went wrong on the server; its log has the details"


class NotFound(Exception):
    """A path the server does not have."""


class App:
    """The server's state: its settings, models, uploads and jobs.

    Parameters
    ----------
    config : ServeConfig
    """

    def __init__(self, config: ServeConfig) -> None:
        self.config = config
        self.catalog = Catalog(config.models, config.known_models, workflow=config.workflow)
        self.uploads = Uploads(config.uploads, config.max_upload_bytes)
        self.board = Board(config, self.catalog)
        root = resources.files("miketalk.serve") / "static"
        self.static = {name: (root / name).read_bytes() for name in STATIC}

    def settings(self) -> dict[str, Any]:
        """What the page needs to know before it asks for anything."""
        return {
            "version": __version__,
            "max_upload_bytes": self.config.max_upload_bytes,
            "voices": [{"name": v.name, "description": v.description} for v in VOICES.values()],
            "default_voice": DEFAULT_VOICE,
            "lipsync_models": list(LIPSYNC_MODELS),
            "build_stages": list(BUILD_STAGES),
        }

    def close(self) -> None:
        """Stop the jobs' threads (a running build is cancelled)."""
        self.board.close()


class Handler(BaseHTTPRequestHandler):
    """One request (see the module docstring)."""

    server_version = f"miketalk/{__version__}"
    protocol_version = "HTTP/1.1"
    timeout = 60  # seconds a stalled connection may keep its thread
    server: Server

    @property
    def app(self) -> App:
        return self.server.app

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("%s " + format, self.address_string(), *args)

    # -- dispatch

    def do_GET(self) -> None:
        self._dispatch(self._get)

    def do_HEAD(self) -> None:
        self._dispatch(self._get)

    def do_POST(self) -> None:
        self._dispatch(self._post)

    def _dispatch(self, route) -> None:
        self._drained = False
        try:
            if not self._host_allowed():
                raise NotFound
            parts = urlsplit(self.path)
            route([unquote(p) for p in parts.path.split("/")[1:]], parse_qs(parts.query))
        except NotFound:
            self._refuse({"error": "not found"}, HTTPStatus.NOT_FOUND)
        except UploadRefused as err:
            self._refuse({"error": str(err)}, err.status)
        except MiketalkError as err:
            self._refuse({"error": " ".join(str(err).split())}, HTTPStatus.BAD_REQUEST)
        except TimeoutError:  # a body that stopped coming: answered, and the thread let go
            log.warning(
                "%s %s: the connection from %s stalled for %g s; closed",
                self.command, urlsplit(self.path).path, self.address_string(), self.timeout,
            )  # fmt: skip
            self._drained = True  # what is left of its body is not read
            message = f"nothing received for {self.timeout:g} s: send it again"
            self._refuse({"error": message}, HTTPStatus.REQUEST_TIMEOUT)
            self.close_connection = True
        except ConnectionError:  # the client left (a broken pipe, a reset)
            self.close_connection = True
        except Exception:
            log.exception("%s %s failed", self.command, self.path)
            self._refuse({"error": _INTERNAL}, HTTPStatus.INTERNAL_SERVER_ERROR)

    def _refuse(self, doc: dict, status: int) -> None:
        """Answer a refused request; a client that left or stalls gets nothing, in silence."""
        try:
            self._json(doc, status, drain=True)
        except OSError:  # a broken pipe, a reset, a timeout: nobody to answer
            self.close_connection = True

    def _host_allowed(self) -> bool:
        """On a loopback address, the Host header names it (no DNS rebinding)."""
        host = self.server.server_address[0]
        with contextlib.suppress(ValueError):
            if not ipaddress.ip_address(host).is_loopback:
                return True
        port = self.server.server_address[1]
        names = {f"127.0.0.1:{port}", f"localhost:{port}", f"[::1]:{port}", f"{host}:{port}"}
        return self.headers.get("Host", "") in names

    def _get(self, parts: list[str], query: dict[str, list[str]]) -> None:
        match parts:
            case [""] | ["index.html"]:
                self._static("page.html")
            case ["favicon.ico"]:
                self._static("icon.svg")
            case ["static", name] if name in STATIC:
                self._static(name)
            case ["api", "config"]:
                self._json(self.app.settings())
            case ["api", "models"]:
                self._json(self.app.catalog.describe())
            case ["api", "models", model_id, "image"]:
                image = self._model(model_id).image()
                if image is None:
                    raise NotFound
                self._file(image, "image/png", cache="max-age=300")
            case ["api", "jobs"]:
                self._json(self.app.board.listing())
            case ["api", "jobs", job_id]:
                self._json(self._job(job_id))
            case ["files", job_id, name]:
                self._job_file(job_id, name, download="download" in query)
            case _:
                raise NotFound

    def _post(self, parts: list[str], query: dict[str, list[str]]) -> None:
        if self.headers.get("X-Miketalk") != "1" or not self._same_origin():
            self._json({"error": "refused: not from the page"}, HTTPStatus.FORBIDDEN, drain=True)
            return
        match parts:
            case ["api", "upload"]:
                uploads = self.app.uploads
                kind = (query.get("kind") or [""])[0]
                name, length = unquote(self.headers.get("X-Miketalk-Name", "")), self._length()
                uploads.check(kind, name, length)  # refused unread
                self._drained = True
                try:
                    upload = uploads.receive(kind, name, length, self.rfile)
                except BaseException:
                    self.close_connection = True  # the rest of the body is not read
                    raise
                self._json({"upload": upload.id, "name": upload.name, "size": upload.size})
            case ["api", "jobs"]:
                app = self.app
                job = make_job(
                    self._read_json(), board=app.board, catalog=app.catalog, uploads=app.uploads
                )
                self._json(app.board.public(job.id), HTTPStatus.CREATED)
            case ["api", "jobs", job_id, "cancel"]:
                self._read_json(optional=True)
                self._json(self.app.board.cancel(job_id))
            case _:
                raise NotFound

    def _same_origin(self) -> bool:
        origin = self.headers.get("Origin")
        return origin is None or origin == f"http://{self.headers.get('Host', '')}"

    # -- looking things up

    def _model(self, model_id: str):
        try:
            return self.app.catalog.get(model_id)
        except MiketalkError:
            raise NotFound from None

    def _job(self, job_id: str) -> dict[str, Any]:
        try:
            return self.app.board.public(job_id)
        except MiketalkError:
            raise NotFound from None

    # -- reading

    def _length(self) -> int | None:
        value = self.headers.get("Content-Length")
        if value is None or not value.isdigit():
            return None
        return int(value)

    def _read_json(self, *, optional: bool = False) -> Any:
        length = self._length() or 0
        if length > MAX_JSON_BYTES:
            raise MiketalkError(f"the request is larger than {MAX_JSON_BYTES} bytes")
        raw = self.rfile.read(length) if length else b""
        self._drained = True
        if not raw and optional:
            return None
        try:
            return json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, ValueError):
            raise MiketalkError("the request is not JSON") from None

    # -- answering

    def _headers(self, status: int, content_type: str, length: int, **more: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(length))
        for name, value in (_SECURITY | more).items():
            self.send_header(name.replace("_", "-"), value)
        self.end_headers()

    def _json(self, doc: Any, status: int = HTTPStatus.OK, *, drain: bool = False) -> None:
        if drain:
            self._drain()
        body = json.dumps(doc, allow_nan=False).encode("utf-8")
        self._headers(status, "application/json", len(body), Cache_Control="no-store")
        if self.command != "HEAD":
            self.wfile.write(body)

    def _drain(self) -> None:
        """Read what is left of a refused request's body (a small one), or close after it."""
        if getattr(self, "_drained", False) or self.command != "POST":
            return
        self._drained = True
        length = self._length() or 0
        if length > 16 << 20:
            self.close_connection = True
            return
        with contextlib.suppress(OSError):
            while length > 0:
                chunk = self.rfile.read(min(length, 1 << 20))
                if not chunk:
                    break
                length -= len(chunk)

    def _static(self, name: str) -> None:
        body = self.app.static[name]
        self._headers(HTTPStatus.OK, STATIC[name], len(body), Cache_Control="no-cache")
        if self.command != "HEAD":
            self.wfile.write(body)

    def _job_file(self, job_id: str, name: str, *, download: bool) -> None:
        try:
            job = self.app.board.get(job_id)
        except MiketalkError:
            raise NotFound from None
        path = job.files.get(name)
        if path is None or not path.is_file():
            raise NotFound
        more = {"Content_Disposition": f'attachment; filename="{job_id}-{name}"'}
        kind = TYPES.get(path.suffix.lower(), "application/octet-stream")
        self._file(path, kind, **(more if download else {}))

    def _file(self, path: Path, kind: str, *, cache: str = "no-cache", **more: str) -> None:
        """``path`` whole, or the byte range asked for."""
        with open(path, "rb") as f:
            size = f.seek(0, 2)
            start, end = 0, size - 1
            status = HTTPStatus.OK
            asked = _RANGE.fullmatch(self.headers.get("Range", "").strip())
            if asked and (asked[1] or asked[2]):
                if asked[1]:
                    start = int(asked[1])
                    end = min(int(asked[2]), size - 1) if asked[2] else size - 1
                else:
                    start = max(0, size - int(asked[2]))
                if start > end or start >= size:
                    self._headers(HTTPStatus.REQUESTED_RANGE_NOT_SATISFIABLE, kind, 0,
                                  Content_Range=f"bytes */{size}")  # fmt: skip
                    return
                status = HTTPStatus.PARTIAL_CONTENT
                more["Content_Range"] = f"bytes {start}-{end}/{size}"
            self._headers(status, kind, end - start + 1, Accept_Ranges="bytes",
                          Cache_Control=cache, **more)  # fmt: skip
            if self.command == "HEAD":
                return
            f.seek(start)
            left = end - start + 1
            while left > 0:
                chunk = f.read(min(left, 1 << 20))
                if not chunk:
                    break
                self.wfile.write(chunk)
                left -= len(chunk)


class Server(ThreadingHTTPServer):
    """The threading HTTP server, holding the :class:`App` (see :func:`make_server`)."""

    daemon_threads = True
    allow_reuse_address = True
    app: App

    def __init__(self, config: ServeConfig) -> None:
        self.address_family = socket.AF_INET6 if ":" in config.host else socket.AF_INET
        super().__init__((config.host, config.port), Handler)

    def server_bind(self) -> None:
        """Bind, without HTTPServer's reverse lookup of the host's name (slow offline)."""
        socketserver.TCPServer.server_bind(self)
        self.server_name, self.server_port = str(self.server_address[0]), self.server_address[1]

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A connection the client left or let stall is one debug line, not a traceback on
        the server's stderr; anything else is logged with its traceback."""
        import sys

        error = sys.exc_info()[1]
        if isinstance(error, ConnectionError | TimeoutError):
            log.debug("connection from %s ended: %s", client_address, error)
            return
        log.exception("a request from %s failed", client_address)


def make_server(config: ServeConfig) -> Server:
    """A server for ``config``, bound and ready for ``serve_forever`` (port 0: a free one,
    ``server_address`` says which).

    Raises
    ------
    MiketalkError
        The address cannot be bound (in use, not this machine's).
    """
    try:
        server = Server(config)
    except OSError as err:
        raise MiketalkError(
            f"cannot listen on {config.host}:{config.port}: {err.strerror or err}"
        ) from None
    try:
        server.app = App(config)
    except BaseException:
        server.server_close()
        raise
    return server
