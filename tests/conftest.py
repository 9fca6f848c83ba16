"""Under ``make test`` (``MIKETALK_NO_SKIP=1``) a skipped test is a failure.

Tests that need Festival or Chromium skip when they are missing, so that a
developer can run the rest without them; ``make test`` and CI install both, and
a skip there would hide a missing install step.

A test's outcome never depends on what ``results/`` holds nor on the caller's
``$MIKETALK_MODEL``: the whole session, its workers and every process they start look
for the workflow's models in an empty folder (``$MIKETALK_RESULTS``), with no
``$MIKETALK_MODEL`` (:func:`pytest_configure`; ``tests/test_suite_rules.py`` checks it).
"""

from __future__ import annotations

import functools
import os
import pickle
import shutil
import signal
import tempfile
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
    """The session's environment, before any test or worker starts.

    - The workflow's models are looked for in an empty folder of this session's
      (``$MIKETALK_RESULTS``), never in the checkout's ``results/``, and the caller's
      ``$MIKETALK_MODEL`` is dropped: a test that needs a model builds or names its own.
      What a run keeps for the next (``$MIKETALK_CACHE``: models' checks, decoded frames)
      is kept in a folder of the session's, not the user's cache.
      The controller sets both; xdist's workers and every process a test starts inherit them.
    - pytest-xdist's workers (``make test`` runs ``-n 2``) start with Ctrl-C ignored, as
      does a pytest started in the background by a shell without job control
      (``pytest ... &``), and the processes they start would inherit that: the tests of
      what Ctrl-C does need Python's own handler, as a terminal gives it.
    - numpy's BLAS runs one thread, as in every command of miketalk's (the command line, a
      build, the workflow's stages: :func:`miketalk.workers.one_blas_thread`): what a test
      calls in its own process fits and draws as the commands do, and OpenBLAS's threads
      do not spin beside the other worker (a build's fits: 7.6 s of CPU with two, 0.9 s
      with one).
    """
    from miketalk.workers import one_blas_thread

    config.add_cleanup(one_blas_thread().restore_original_limits)
    os.environ.pop("MIKETALK_MODEL", None)
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        empty = Path(tempfile.mkdtemp(prefix="miketalk-test-results-"))
        os.environ["MIKETALK_RESULTS"] = str(empty)
        cache = Path(tempfile.mkdtemp(prefix="miketalk-test-cache-"))
        os.environ["MIKETALK_CACHE"] = str(cache)  # what a run keeps for the next: the session's
        config.add_cleanup(lambda: shutil.rmtree(empty, ignore_errors=True))
        config.add_cleanup(lambda: shutil.rmtree(cache, ignore_errors=True))
    signal.signal(signal.SIGINT, signal.default_int_handler)


def made_once(factory: pytest.TempPathFactory, name: str, make) -> Path:
    """The folder ``name`` that ``make(folder)`` filled, made once for the whole session.

    Under ``pytest -n 2`` each xdist worker has its own session, and a session fixture
    used by files on both workers was built twice (a model from video: 40 s each). Here the
    first worker to ask builds into the session's shared temporary folder, under a lock,
    and marks it done; the other waits on the lock and takes it. A build that failed
    leaves no mark, and the next to ask builds again. What is made this way is only read.
    """
    import fcntl

    base = factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    where, done = shared / name, shared / f"{name}.done"
    with open(shared / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(where, ignore_errors=True)
            where.mkdir()
            make(where)
            done.touch()
    return where


@pytest.fixture(scope="session")
def s1_joined(tmp_path_factory: pytest.TempPathFactory):
    """The .test face s1's six clips (four training, two held-out) joined into one 18 s
    video, with its plain transcript and an SRT of sentence cues from GRID's word
    timings (made here from the committed clips: no new data)."""
    from miketalk_lab.bench.joined import join_clips

    s1 = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["faces"]["s1"]["corpus"]

    def join(where: Path) -> None:
        joined = join_clips(
            s1["train"] + s1["test"],
            where,
            media=str(ROOT / s1["media"]),
            transcripts=ROOT / s1["transcripts"],
            timings=str(ROOT / s1["timings"]),
        )
        (where / "joined.pickle").write_bytes(pickle.dumps(joined))

    where = made_once(tmp_path_factory, "s1_joined", join)
    return pickle.loads((where / "joined.pickle").read_bytes())


def _build_s1(where: Path, *, crop: bool, joined) -> None:
    from miketalk.building.from_video import build_model_from_video

    config = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["flow"]
    build_model_from_video(
        joined.video,
        where / "model",
        transcript=joined.transcript,
        heldout_seconds=6,
        progress=False,
        flow=config["methods"][config["method"]],
        mixed_window=config["mixed_window"],
        **({} if crop else {"keep_corpus": where / "corpus", "crop": None}),
    )


@pytest.fixture(scope="session")
def s1_built(s1_joined, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The model ``miketalk build --frame full`` makes of the joined video with its plain
    transcript, its last 6 s (the two held-out clips) held out, with the .test workflow's flow
    settings (so that it compares with the .test face s1, in the frames' own pixels); its
    corpus kept beside it (``corpus/``). Built once for the session (:func:`made_once`)."""
    build = functools.partial(_build_s1, crop=False, joined=s1_joined)
    return made_once(tmp_path_factory, "s1_built", build) / "model"


@pytest.fixture(scope="session")
def s1_crop_built(s1_joined, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The model ``miketalk build``'s default (the face crop) makes of the same video with
    the same settings as :func:`s1_built`. Built once for the session (:func:`made_once`)."""
    build = functools.partial(_build_s1, crop=True, joined=s1_joined)
    return made_once(tmp_path_factory, "s1_crop_built", build) / "model"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The slow end-to-end tests first (a stable sort): under ``pytest -n 2 --dist loadfile``
    (``make test``) their files start at once on one worker while the rest share the other,
    instead of starting last."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


@pytest.fixture()
def work_started(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    """Festival and ffmpeg through wrappers that note each start; the notes' path.

    A refusal "before any work" is tested by what never started, not by how fast it came:
    ``$MIKETALK_FESTIVAL`` and ``$IMAGEIO_FFMPEG_EXE`` (imageio-ffmpeg's own setting) name
    the wrappers, in this process and every process it starts, and each start of either
    appends ``festival ARGS`` or ``ffmpeg ARGS`` as one line of the returned file, which
    stays absent while neither ran.
    """
    import shlex

    import imageio_ffmpeg

    where = tmp_path_factory.mktemp("work_started")
    notes = where / "started.txt"
    programs = {
        "festival": shutil.which(os.environ.get("MIKETALK_FESTIVAL") or "festival") or "festival",
        "ffmpeg": imageio_ffmpeg.get_ffmpeg_exe(),
    }
    for name, real in programs.items():
        wrapper = where / name
        wrapper.write_text(
            f'#!/bin/sh\necho "{name} $*" >> {shlex.quote(str(notes))}\n'
            f'exec {shlex.quote(real)} "$@"\n'
        )
        wrapper.chmod(0o755)
    monkeypatch.setenv("MIKETALK_FESTIVAL", str(where / "festival"))
    monkeypatch.setenv("IMAGEIO_FFMPEG_EXE", str(where / "ffmpeg"))
    return notes


@pytest.fixture()
def finishes():
    """``finishes(call, within=60)``: ``call()``'s result (or its exception), failing the
    test when it has not returned after ``within`` seconds.

    For a call whose fault would be never to return (a read to the end of an endless
    device, a wait for a child that never ends): a generous deadline on a poll, never an
    assertion on how fast it returned.
    """
    import threading

    def run(call, *, within: float = 60.0):
        outcome: dict = {}

        def target() -> None:
            try:
                outcome["value"] = call()
            except BaseException as err:  # handed to the test's thread
                outcome["error"] = err

        thread = threading.Thread(target=target, daemon=True)
        thread.start()
        thread.join(within)
        if thread.is_alive():
            pytest.fail(f"{call!r} had not returned after {within} s")
        if "error" in outcome:
            raise outcome["error"]
        return outcome.get("value")

    return run
