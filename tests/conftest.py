"""Under ``make test`` (``MIKETALK_NO_SKIP=1``) a skipped test is a failure.

Tests that need Festival or Chromium skip when they are missing, so that a
developer can run the rest without them; ``make test`` and CI install both, and
a skip there would hide a missing install step.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
import yaml


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    outcome = yield
    report = outcome.get_result()
    if report.skipped and os.environ.get("MIKETALK_NO_SKIP") == "1":
        reason = report.longrepr[-1] if isinstance(report.longrepr, tuple) else report.longrepr
        report.outcome = "failed"
        report.longrepr = f"skipped under make test (MIKETALK_NO_SKIP=1): {reason}"


ROOT = Path(__file__).resolve().parents[1]


def pytest_configure(config: pytest.Config) -> None:
    """pytest-xdist's workers (``make test`` runs ``-n 2``) start with Ctrl-C ignored, and
    the processes they start would inherit that: the tests of what Ctrl-C does need Python's
    own handler, as a terminal gives it."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def s1_joined(tmp_path_factory: pytest.TempPathFactory):
    """The .test face s1's six clips (four training, two held-out) joined into one 18 s
    video, with its plain transcript and an SRT of sentence cues from GRID's word
    timings (made here from the committed clips: no new data)."""
    from miketalk_lab.bench.joined import join_clips

    s1 = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["faces"]["s1"]["corpus"]
    return join_clips(
        s1["train"] + s1["test"],
        tmp_path_factory.mktemp("s1_joined"),
        media=str(ROOT / s1["media"]),
        transcripts=ROOT / s1["transcripts"],
        timings=str(ROOT / s1["timings"]),
    )


@pytest.fixture(scope="session")
def s1_built(s1_joined, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The model ``miketalk build --frame full`` makes of the joined video with its plain
    transcript, its last 6 s (the two held-out clips) held out, with the .test workflow's flow
    settings (so that it compares with the .test face s1, in the frames' own pixels); its
    corpus kept beside it (``corpus/``)."""
    from miketalk.building.from_video import build_model_from_video

    config = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["flow"]
    where = tmp_path_factory.mktemp("s1_built")
    build_model_from_video(
        s1_joined.video,
        where / "model",
        transcript=s1_joined.transcript,
        heldout_seconds=6,
        progress=False,
        flow=config["methods"][config["method"]],
        mixed_window=config["mixed_window"],
        keep_corpus=where / "corpus",
        crop=None,
    )
    return where / "model"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The slow end-to-end tests first (a stable sort): under ``pytest -n 2 --dist loadfile``
    (``make test``) their files start at once on one worker while the rest share the other,
    instead of starting last."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
