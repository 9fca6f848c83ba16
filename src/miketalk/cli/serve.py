"""``miketalk serve``: the page in the browser (:mod:`miketalk.serve`).

``miketalk serve [--port N] [--host H] [--results DIR] [--models DIR]`` serves a page, on
this machine only unless --host says otherwise, that builds a face from an uploaded video
and its transcript or subtitles (its stages and a progress bar, and a cancel that leaves
nothing behind), lists the models (the workflow's results/model/*, --model DIR, and those
built on the page, in --models), makes a model speak typed text or a recording (the mp4
plays in the page, with a download link and its mouth cues) and dubs an uploaded video.
Every job writes into a new folder of --results; uploads over --max-upload-mb are refused.
A mistake shows the one line the command line would print. Ctrl-C stops the server (and a
running build, leaving nothing half-written).
"""

from __future__ import annotations

import argparse
import ipaddress
import logging
import sys
import threading
from pathlib import Path

from miketalk.api import MiketalkError

__all__ = ["add_serve_parser", "cmd_serve"]


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, not {text}")
    return value


def _port(text: str) -> int:
    if not text.isdigit() or not 0 <= int(text) <= 65535:
        raise argparse.ArgumentTypeError(f"a port is a number from 0 to 65535, not {text!r}")
    return int(text)


def cmd_serve(args: argparse.Namespace) -> int:
    """Serve the page until Ctrl-C or SIGTERM (see the module docstring)."""
    from miketalk.serve.app import make_server
    from miketalk.serve.config import ServeConfig

    if args.workers < 1:
        raise MiketalkError(f"--workers must be at least 1, not {args.workers}")
    for model in args.model or ():
        if not (Path(model) / "manifest.json").is_file():
            raise MiketalkError(
                f"--model {model}: no model there (no manifest.json): give a folder made by "
                "miketalk build or the workflow"
            )
    config = ServeConfig(
        results=args.results,
        models=args.models,
        known_models=tuple(args.model or ()),
        host=args.host,
        port=args.port,
        max_upload_bytes=int(args.max_upload_mb * (1 << 20)),
        workers=args.workers,
    )
    server = make_server(config)
    host, port = server.server_address[:2]
    shown = f"[{host}]" if ":" in host else host
    print(
        f"miketalk serve: http://{shown}:{port}/ (jobs in {config.results}, models built into "
        f"{config.models}); Ctrl-C stops it",
        file=args.out,
    )
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        print(
            f"miketalk serve: warning: listening on {host}: anyone who can reach this machine "
            "can use the page and its files",
            file=sys.stderr,
        )
    serving = threading.Thread(target=server.serve_forever, name="miketalk-serve", daemon=True)
    serving.start()
    try:
        while serving.is_alive():  # Ctrl-C and SIGTERM land in this (the main) thread
            serving.join(0.25)
    except KeyboardInterrupt:
        print("miketalk serve: stopping", file=sys.stderr)
    finally:
        server.app.close()  # the jobs first: a stream being played ends with its job
        server.shutdown()
        server.server_close()
    logging.getLogger("miketalk").info("miketalk serve stopped")
    return 0


def add_serve_parser(sub) -> None:
    """Add ``serve`` to the CLI's sub-commands."""
    from miketalk.cli.options import verbose_option
    from miketalk.serve.config import (
        DEFAULT_HOST,
        DEFAULT_MAX_UPLOAD_MB,
        DEFAULT_PORT,
        DEFAULT_RESULTS,
    )

    serve = sub.add_parser(
        "serve",
        help="a page in the browser: build a face, make it speak, dub a video",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    serve.add_argument(
        "--port", type=_port, default=DEFAULT_PORT,
        help=f"the port to listen on (default {DEFAULT_PORT}; 0: any free port)",
    )  # fmt: skip
    serve.add_argument(
        "--host", default=DEFAULT_HOST,
        help=f"the address to listen on (default {DEFAULT_HOST}: this machine only; "
        "0.0.0.0 opens the page to the network)",
    )  # fmt: skip
    serve.add_argument(
        "--results", default=str(DEFAULT_RESULTS),
        help=f"the folder jobs write into, a new folder each (default ./{DEFAULT_RESULTS})",
    )  # fmt: skip
    serve.add_argument(
        "--models", default=None,
        help="where models built on the page go, and are listed from (default RESULTS/models)",
    )  # fmt: skip
    serve.add_argument(
        "--model", action="append", metavar="DIR",
        help="also list this model (may be given several times); the workflow's "
        "results/model/* are listed anyway",
    )  # fmt: skip
    serve.add_argument(
        "--max-upload-mb", type=_positive, default=DEFAULT_MAX_UPLOAD_MB,
        help=f"the largest upload, megabytes (default {DEFAULT_MAX_UPLOAD_MB})",
    )  # fmt: skip
    serve.add_argument("--workers", type=int, default=2, help="cores a build uses (default 2)")
    verbose_option(serve)
    serve.set_defaults(func=cmd_serve)
