"""``miketalk serve``: a page in the browser over the library.

Starlette on uvicorn (:mod:`miketalk.serve.app`) serves one static page (``static/page.html``,
``page.js``, ``page.css``) and JSON endpoints (:mod:`miketalk.serve.routes`), under the security
rules of :mod:`miketalk.serve.guard`. The page builds a model from an uploaded video and its
transcript or subtitles, lists the models the server knows (:mod:`miketalk.serve.catalog`),
makes a model speak typed text or a recording, and dubs a video. Long work runs in the
background (:mod:`miketalk.serve.jobs`): ``say`` and ``dub`` one after the other in a worker
thread, a build in a child process of its own that a cancel terminates
(:mod:`miketalk.serve.work`).

The safety rules: the server listens on 127.0.0.1 unless told otherwise; every file it writes is
named by the server (an upload's name is shown, never used as a path; a model is chosen by an id
from the server's own list; each job writes into a new folder the server names); uploads have a
size limit; the text typed goes to :func:`miketalk.api.say`, which hands it to Festival through
a file; a mistake is the library's one-line :class:`MiketalkError` text, and any other failure
is logged on the server with its traceback and shown as one line.
"""

from __future__ import annotations

from miketalk.serve.config import ServeConfig

__all__ = ["ServeConfig"]
