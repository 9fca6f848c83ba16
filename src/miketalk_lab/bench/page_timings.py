"""The page's times in a real browser: Debian's Chromium, headless, driven by Playwright.

:func:`page_figures` starts ``miketalk serve`` on a free port of 127.0.0.1 with the given
models, and measures, each the median of ``repeats``: the page loaded until it has listed
its models (``page_load_s``), ``/api/models`` answered from the page (``page_api_s``), and,
per model, Speak clicked to the video playing (``page_speak_to_play_s_<face>``, the page's
own ``performance.now()`` at the ``playing`` event). ``tests/product/test_serve.py`` holds
what the page must do; this holds how fast it did it.
"""

from __future__ import annotations

import contextlib
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator

from miketalk.errors import MiketalkError

CHROMIUM = pathlib.Path("/usr/bin/chromium")
#: Chromium's switches as root in a container, without a network of its own.
FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip


def speak(
    page, label: str, text: str, *, until: str = "sinceClick", timeout_s: float = 120
) -> None:
    """Choose the face ``label``, type ``text`` and click Speak; return once the player has
    the mark ``until`` (``sinceClick``: playing; ``firstFrame``: its first frame shown)."""
    page.bring_to_front()
    page.click("#tab-say")
    page.locator("#models li", has_text=label).first.click()
    page.wait_for_selector(f"#models li[aria-checked='true']:has-text('{label}')")
    page.fill("#say-form textarea[name=text]", text)
    page.evaluate(f"delete document.getElementById('player').dataset.{until}")
    page.click("#say-form button[type=submit]")
    mark = "data-" + "".join(f"-{c.lower()}" if c.isupper() else c for c in until)
    page.wait_for_selector(f"#player[{mark}]", state="attached", timeout=timeout_s * 1000)


def _speak_seconds(page, label: str, text: str) -> float:
    speak(page, label, text)
    since = page.evaluate("Number(document.getElementById('player').dataset.sinceClick)")
    page.evaluate("document.getElementById('player').pause()")
    return float(since)


@contextlib.contextmanager
def served_page(models: dict[str, pathlib.Path], *, height: int = 860) -> Iterator[tuple]:
    """``miketalk serve`` of ``models`` on a free port of 127.0.0.1 and a new page of Debian's
    Chromium (headless, a fresh profile): ``(page, url, server)``; both stopped after."""
    from playwright.sync_api import sync_playwright

    if not CHROMIUM.is_file():
        raise MiketalkError("chromium not installed (apt-get install chromium)")
    with tempfile.TemporaryDirectory() as scratch:
        tmp = pathlib.Path(scratch)
        command = [sys.executable, "-m", "miketalk.cli", "serve", "--port", "0", "--results",
                   str(tmp / "jobs"), "--models", str(tmp / "models")]  # fmt: skip
        for model in models.values():
            command += ["--model", str(model)]
        server = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
        )
        try:
            address = server.stdout.readline().split("http://")[1].split("/")[0]
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch_persistent_context(
                    str(tmp / "profile"), executable_path=str(CHROMIUM), headless=True,
                    args=FLAGS, viewport={"width": 1280, "height": height},
                )  # fmt: skip
                try:
                    yield browser.new_page(), f"http://{address}/", server
                finally:
                    browser.close()
        finally:
            server.terminate()
            server.communicate(timeout=60)


def page_figures(
    models: dict[str, pathlib.Path], sentence: str, *, repeats: int = 3
) -> dict[str, float]:
    """The page's figures for ``models`` (label -> model folder) speaking ``sentence``."""
    with served_page(models) as (page, url, _):
        loads, answers = [], []
        for _ in range(repeats):
            started = time.perf_counter()
            page.goto(url)
            page.wait_for_selector("body[data-ready='1']", timeout=60_000)
            loads.append(time.perf_counter() - started)
            started = time.perf_counter()
            page.evaluate("fetch('/api/models').then(r => r.json())")
            answers.append(time.perf_counter() - started)
        figures = {
            "page_load_seconds": round(statistics.median(loads), 3),
            "page_api_seconds": round(statistics.median(answers), 4),
        }
        for label, model in models.items():
            runs = [_speak_seconds(page, model.name, sentence) for _ in range(repeats)]
            figures[f"page_speak_to_play_seconds_{label}"] = round(statistics.median(runs), 3)
    return figures
