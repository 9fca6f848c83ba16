"""The server's settings: where it listens, where it keeps things, how large an upload may be."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

#: The address the server listens on unless ``--host`` says otherwise: this machine only.
DEFAULT_HOST = "127.0.0.1"
#: The port of ``miketalk serve`` without ``--port``.
DEFAULT_PORT = 8765
#: The largest upload, megabytes (``--max-upload-mb``): minutes of HD video of a person.
DEFAULT_MAX_UPLOAD_MB = 512
#: Where jobs' folders go without ``--results`` (under the working directory).
DEFAULT_RESULTS = Path("miketalk-serve")
#: The largest JSON body of a request (a job's settings and text), bytes.
MAX_JSON_BYTES = 1 << 20
#: Seconds a request's body may stop coming before it is answered 408 and let go.
DEFAULT_STALL_SECONDS = 60.0
#: The longest text a job speaks, characters (with :data:`MAX_TEXT_WORDS`, stated in the page
#: before any work; a longer text is refused, never cut).
MAX_TEXT_CHARS = 100_000
#: The most words a job speaks: the library's own limit (some 60 minutes of speech, played
#: live as it is made; ``tests/product/test_serve_http.py`` holds the two equal).
MAX_TEXT_WORDS = 10_000


@dataclass(frozen=True)
class ServeConfig:
    """What ``miketalk serve`` was started with.

    Attributes
    ----------
    results : Path
        The folder every job writes into (a new folder per job, named by the server);
        uploads wait in its ``.uploads/`` until a job takes them.
    models : Path
        Where the models built on the page go (one folder each, named by the server); they
        are listed with the others.
    known_models : tuple of Path
        Models to list besides those under ``models`` (and the workflow's, see
        :func:`miketalk.serve.catalog.workflow_models`), read only.
    host, port : str, int
        The address to listen on (port 0: any free port).
    max_upload_bytes : int
        The largest upload; a larger one is refused in one line.
    workers : int
        Cores a build uses.
    build_options : mapping
        More keyword arguments of
        :func:`miketalk.building.from_video.build_model_from_video` (``flow``,
        ``mixed_window``: the tests build with the ``.test`` workflow's quicker flows).
    workflow : bool
        Also list the models of the workflow's results (``results/model/*``).
    stall_seconds : float
        How long a request's body may stop coming before it is answered 408 and its
        connection closed.
    """

    results: Path = DEFAULT_RESULTS
    models: Path | None = None
    known_models: tuple[Path, ...] = ()
    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT
    max_upload_bytes: int = DEFAULT_MAX_UPLOAD_MB << 20
    workers: int = 2
    build_options: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    workflow: bool = True
    stall_seconds: float = DEFAULT_STALL_SECONDS

    def __post_init__(self) -> None:
        results = Path(os.path.abspath(self.results))
        object.__setattr__(self, "results", results)
        models = results / "models" if self.models is None else Path(os.path.abspath(self.models))
        object.__setattr__(self, "models", models)
        known = tuple(Path(os.path.abspath(p)) for p in self.known_models)
        object.__setattr__(self, "known_models", known)
        object.__setattr__(self, "build_options", MappingProxyType(dict(self.build_options)))

    @property
    def uploads(self) -> Path:
        """Where uploads wait for the job that takes them."""
        return self.results / ".uploads"
