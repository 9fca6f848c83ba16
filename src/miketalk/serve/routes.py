"""The page's routes on Starlette: one static page, JSON endpoints, the files jobs made.

Routes (``GET`` unless said)::

    /                               the page (static/page.html, page.js, page.css)
    /api/config                     the upload limit, voices, lip-sync models, build stages
    /api/models                     the models (ids, names, what each can do)
    /api/models/<id>/image          a picture of a model's face
    POST /api/upload?kind=K         a file as the raw body (K: video, audio, script) -> its id
    POST /api/jobs                  a job as JSON (say, dub, build) -> the job
    /api/jobs, /api/jobs/<id>       the jobs, one job
    POST /api/jobs/<id>/cancel      cancel a queued job, stop a running live one or a build
    /api/jobs/<id>/live             a live job's fragmented MP4 from its start, as it is made
    /files/<job>/<name>             a file the job made (byte ranges; ``?download``: as a
                                    download named after the job)

An upload's body is the file's bytes, by its length or chunked, written as they come
(:mod:`miketalk.serve.bodies`). The security rules are :mod:`miketalk.serve.guard`'s. A
mistake is ``{"error": "<one line>"}`` with status 400 (413 for an upload over the limit,
404 for what the server does not have); a body that stops coming for
:attr:`~miketalk.serve.config.ServeConfig.stall_seconds` gets 408 and its connection closed
(one warning line); a client that leaves mid-request is let go without a word; anything else
is logged with its traceback and the page gets one line (500).
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Awaitable, Callable
from importlib import resources
from pathlib import Path

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import Route

from miketalk.api import MiketalkError
from miketalk.serve.bodies import ClientLeft, Stalled, pieces, read_json
from miketalk.serve.config import MAX_JSON_BYTES
from miketalk.serve.forms import make_job
from miketalk.serve.guard import Guard, allowed_hosts, error
from miketalk.serve.live import follow
from miketalk.serve.records import FINAL, download_name
from miketalk.serve.state import App
from miketalk.serve.uploads import UploadRefused

log = logging.getLogger(__name__)

#: The page's files and their types.
STATIC = {
    "page.html": "text/html; charset=utf-8",
    "page.js": "text/javascript; charset=utf-8",
    "live.js": "text/javascript; charset=utf-8",
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
_INTERNAL = "something went wrong on the server; its log has the details"


class NotFound(Exception):
    """A path the server does not have."""


Endpoint = Callable[[Request], Awaitable[Response]]


def _answered(handler: Endpoint) -> Endpoint:
    """``handler`` with every failure answered in one line (see the module docstring)."""

    @functools.wraps(handler)
    async def answer(request: Request) -> Response:
        try:
            return await handler(request)
        except NotFound:
            return error("not found", 404, request)
        except UploadRefused as err:
            return error(str(err), err.status, request)
        except MiketalkError as err:
            return error(" ".join(str(err).split()), 400, request)
        except Stalled as err:
            where = f"{request.method} {request.url.path}"
            log.warning("%s: the connection from %s stalled for %g s; closed",
                        where, _client(request), err.seconds)  # fmt: skip
            request.state.body_read = False  # what is left of it is not read: closed
            return error(f"nothing received for {err.seconds:g} s: send it again", 408, request)
        except ClientLeft:
            log.debug("%s %s: the client left", request.method, request.url.path)
            return Response(status_code=400, headers={"connection": "close"})
        except Exception:
            log.exception("%s %s failed", request.method, request.url.path)
            return error(_INTERNAL, 500, request)

    return answer


def _client(request: Request) -> str:
    return request.client.host if request.client else "?"


def _app(request: Request) -> App:
    return request.app.state.miketalk


def _json(doc: object, status: int = 200) -> JSONResponse:
    return JSONResponse(doc, status, headers={"cache-control": "no-store"})


# -- the page and what it asks


def _static(name: str) -> Endpoint:
    root = resources.files("miketalk.serve") / "static"

    @_answered
    async def static(request: Request) -> Response:
        path = Path(str(root / name))
        return FileResponse(path, media_type=STATIC[name], headers={"cache-control": "no-cache"})

    return static


@_answered
async def static_file(request: Request) -> Response:
    name = request.path_params["name"]
    if name not in STATIC:
        raise NotFound
    return await _static(name)(request)


@_answered
async def settings(request: Request) -> Response:
    return _json(_app(request).settings())


@_answered
async def models(request: Request) -> Response:
    return _json(await run_in_threadpool(_app(request).catalog.describe))


@_answered
async def model_image(request: Request) -> Response:
    catalog = _app(request).catalog
    try:
        entry = catalog.get(request.path_params["model_id"])
    except MiketalkError:
        raise NotFound from None
    image = await run_in_threadpool(entry.image)
    if image is None:
        raise NotFound
    return FileResponse(image, media_type="image/png", headers={"cache-control": "max-age=300"})


# -- uploads and jobs


@_answered
async def upload(request: Request) -> Response:
    app = _app(request)
    uploads = app.uploads
    kind = request.query_params.get("kind", "")
    length = request.headers.get("content-length")
    chunked = "chunked" in request.headers.get("transfer-encoding", "").lower()
    size = int(length) if length is not None and length.isdigit() and not chunked else None
    if size is None and not chunked:
        uploads.check(kind, _name(request), None)  # 411, unread
    receiving = uploads.begin(kind, _name(request), size)  # refused unread
    try:
        async for piece in pieces(request, app.config.stall_seconds):
            receiving.write(piece)
        kept = receiving.done()
    except BaseException:
        receiving.discard()
        raise
    return _json({"upload": kept.id, "name": kept.name, "size": kept.size})


def _name(request: Request) -> str:
    from urllib.parse import unquote

    return unquote(request.headers.get("x-miketalk-name", ""))


@_answered
async def jobs(request: Request) -> Response:
    app = _app(request)
    if request.method == "GET":
        return _json(app.board.listing())
    body = await read_json(request, app.config.stall_seconds, MAX_JSON_BYTES)
    job = await run_in_threadpool(
        make_job, body, board=app.board, catalog=app.catalog, uploads=app.uploads
    )
    return _json(app.board.public(job.id), 201)


@_answered
async def job(request: Request) -> Response:
    try:
        return _json(_app(request).board.public(request.path_params["job_id"]))
    except MiketalkError:
        raise NotFound from None


@_answered
async def cancel(request: Request) -> Response:
    app = _app(request)
    await read_json(request, app.config.stall_seconds, MAX_JSON_BYTES, optional=True)
    try:
        app.board.get(request.path_params["job_id"])
    except MiketalkError:
        raise NotFound from None
    return _json(await run_in_threadpool(app.board.cancel, request.path_params["job_id"]))


@_answered
async def live(request: Request) -> Response:
    try:
        found = _app(request).board.get(request.path_params["job_id"])
    except MiketalkError:
        raise NotFound from None
    if found.live is None:
        raise NotFound
    return StreamingResponse(
        follow(found.live, until=lambda: found.status in FINAL),
        media_type="video/mp4", headers={"cache-control": "no-store"},
    )  # fmt: skip


@_answered
async def job_file(request: Request) -> Response:
    app = _app(request)
    try:
        found = app.board.get(request.path_params["job_id"])
    except MiketalkError:
        raise NotFound from None
    name = request.path_params["name"]
    path = found.files.get(name)
    if path is None or not path.is_file():
        raise NotFound
    kind = TYPES.get(path.suffix.lower(), "application/octet-stream")
    download = download_name(found.id, name, found.shown.get("text"))
    return FileResponse(
        path, media_type=kind, headers={"cache-control": "no-cache"},
        filename=download if "download" in request.query_params else None,
    )  # fmt: skip


# -- the app


async def _not_found(request: Request, exc: Exception) -> Response:
    if isinstance(exc, HTTPException) and exc.status_code == 405:
        return error("not allowed here", 405, request)
    return error("not found", 404, request)


def asgi(app: App, host: str, port: int) -> Guard:
    """The ASGI application serving ``app`` on ``host``:``port``, its rules kept."""
    routes = [
        Route("/", _static("page.html")),
        Route("/index.html", _static("page.html")),
        Route("/favicon.ico", _static("icon.svg")),
        Route("/static/{name}", static_file),
        Route("/api/config", settings),
        Route("/api/models", models),
        Route("/api/models/{model_id}/image", model_image),
        Route("/api/upload", upload, methods=["POST"]),
        Route("/api/jobs", jobs, methods=["GET", "POST"]),
        Route("/api/jobs/{job_id}", job),
        Route("/api/jobs/{job_id}/cancel", cancel, methods=["POST"]),
        Route("/api/jobs/{job_id}/live", live),
        Route("/files/{job_id}/{name}", job_file),
    ]
    star = Starlette(routes=routes, exception_handlers={HTTPException: _not_found})
    star.state.miketalk = app
    return Guard(star, allowed_hosts(host, port), app.config.stall_seconds)
