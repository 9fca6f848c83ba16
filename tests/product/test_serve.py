"""``miketalk serve`` in a real headless browser: Debian's Chromium driven by Playwright.

One server (on a free port of 127.0.0.1, in this process) and one browser serve the module.
The page loads within a second. A build of two of the ``.test`` face s1's clips starts in a
tab of its own and shows its stages; while it runs, the other tab speaks: typed text plays
as a ``<video>`` as long as its audio, with its mouth cues and download links, on the
synthetic face (and on the workflow's s1 where ``make run`` made it); a second tab writes its
own folder; a text file named ``.mp4`` is the library's one line in the page; a file name
that climbs out of the folder is only shown; a request from elsewhere, an upload over the
limit and a bad job are each one line. Then the build ends with its stages shown and a face
that speaks, and a cancelled build leaves nothing. A model the server keeps open is checked
again when one of its files changes. After Speak the result is announced and focused, and on
a phone's screen; the jobs are reached by the keyboard, show their place in the queue and can
be cancelled; the text's limit is stated before any work and a longer text refused, never
cut; a build's warnings are shown and logged once, and its messages name the uploaded video.
``MIKETALK_SERVE_SHOTS=DIR`` saves screenshots there.
"""

from __future__ import annotations

import contextlib
import http.client
import json
import logging
import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

from miketalk import cli
from miketalk.media.video import probe_durations
from miketalk.speech import FestivalBackend

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
#: Chromium's switches as root in a container, without a network of its own.
FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip
#: Two of the .test face s1's training clips: the shortest video that builds a face.
CLIPS = ["bbaf2n", "lgwg2n"]
SHOTS = os.environ.get("MIKETALK_SERVE_SHOTS")


def shot(page, name: str) -> None:
    """A screenshot into ``$MIKETALK_SERVE_SHOTS`` when it is set."""
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(Path(SHOTS) / f"{name}.png"), full_page=True)


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small synthetic face (test_cli's shifted texture, exact flows)."""
    from test_cli import shifted_model

    return shifted_model(tmp_path_factory.mktemp("synthetic_face"), 64)


@pytest.fixture(scope="module")
def joined(tmp_path_factory: pytest.TempPathFactory):
    """Two of .test s1's clips joined into one 6 s video with its transcript."""
    from miketalk_lab.bench.joined import join_clips

    s1 = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["faces"]["s1"]["corpus"]
    return join_clips(
        CLIPS, tmp_path_factory.mktemp("joined"), media=str(ROOT / s1["media"]),
        transcripts=ROOT / s1["transcripts"], timings=str(ROOT / s1["timings"]),
    )  # fmt: skip


@pytest.fixture(scope="module")
def server(synthetic: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """The server, on a free port of 127.0.0.1, building with the .test workflow's flows."""
    if not FestivalBackend().is_available():
        pytest.skip("Festival not installed")
    from miketalk.serve.app import make_server
    from miketalk.serve.config import ServeConfig

    flow = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["flow"]
    quick = {"flow": flow["methods"][flow["method"]], "mixed_window": flow["mixed_window"]}
    root = tmp_path_factory.mktemp("serve")
    config = ServeConfig(
        results=root / "results", models=root / "models", host="127.0.0.1", port=0,
        known_models=(synthetic,),
        workflow=False, max_upload_bytes=64 << 20,
        build_options=quick,
    )  # fmt: skip
    httpd = make_server(config)
    httpd.logged = []  # what the server logged (its warnings: each once)
    handler = logging.Handler(logging.WARNING)
    handler.emit = lambda record: httpd.logged.append(record.getMessage())
    logging.getLogger("miketalk").addHandler(handler)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.1})
    thread.start()
    yield httpd
    logging.getLogger("miketalk").removeHandler(handler)
    httpd.shutdown()
    thread.join()
    httpd.server_close()
    httpd.app.close()


@pytest.fixture(scope="module")
def url(server) -> str:
    host, port = server.server_address[:2]
    return f"http://{host}:{port}/"


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """Debian's Chromium, headless, with a fresh profile (never `playwright install`)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright not installed (pip install -e .[dev])")
    if not CHROMIUM.is_file():
        pytest.skip("chromium not installed (apt-get install chromium)")
    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("profile")), executable_path=str(CHROMIUM),
            headless=True, args=FLAGS, viewport={"width": 1280, "height": 860},
        )  # fmt: skip
        # Playwright waits up to this for an element to be there and ready: a poll's generous
        # bound (its 30 s default ran out once at a load of 18: a click on a starved page)
        context.set_default_timeout(180_000)
        yield context
        context.close()


@pytest.fixture(scope="module")
def page(browser, url):
    """The page, with what it logged as errors in ``page.errors``."""
    page = browser.new_page()
    page.errors = []
    page.on("pageerror", lambda err: page.errors.append(str(err)))
    page.on("console", lambda m: page.errors.append(m.text) if m.type == "error" else None)
    page.on("response", lambda r: page.errors.append(r.url) if r.status >= 400 else None)
    return page


def _open(page, url: str) -> None:
    """Load the page until it has listed the models (its speed: ``make bench``,
    :mod:`miketalk_lab.bench.responsiveness`)."""
    page.bring_to_front()
    page.goto(url)
    page.wait_for_selector("body[data-ready='1']", timeout=30_000)


def _choose(page, label: str) -> None:
    page.locator("#models li", has_text=label).first.click()
    page.wait_for_selector(f"#models li[aria-checked='true']:has-text('{label}')")


def _say(page, label: str, text: str) -> dict:
    """Type ``text`` for the face ``label`` and click Speak; once its first frame is on the
    screen (played as it is made) and the whole has been played in, what the page and the
    server say of it."""
    page.bring_to_front()  # a page behind another has its animation frames throttled
    page.click("#tab-say")
    _choose(page, label)
    page.fill("#say-form textarea[name=text]", text)
    page.evaluate("delete document.getElementById('player').dataset.firstFrame")
    page.click("#say-form button[type=submit]")
    page.wait_for_selector("#player[data-first-frame]", state="attached", timeout=60_000)
    page.wait_for_selector("#player[data-live-ended]", state="attached", timeout=120_000)
    page.wait_for_selector("#result[data-job]", state="attached", timeout=60_000)
    seen = page.evaluate(
        """() => { const v = document.getElementById('player');
        return {duration: v.duration, since: Number(v.dataset.firstFrame), job: v.dataset.job,
                stalls: Number(v.dataset.stalls),
                cues: document.querySelectorAll('#cues .cue').length,
                mp4: document.getElementById('get-mp4').href}; }"""
    )
    seen["error"] = page.locator("#say-form .error").is_visible()
    return seen


def _job_folder(server, job_id: str) -> Path:
    folder = server.app.config.results / job_id
    assert folder.is_dir() and folder.parent == server.app.config.results
    return folder


def _build(page, joined, name: str) -> None:
    page.bring_to_front()
    page.click("#tab-build")
    page.fill("#build-form input[name=name]", name)
    page.set_input_files("#build-form input[name=video]", str(joined.video))
    page.set_input_files("#build-form input[name=script]", str(joined.transcript))
    page.click("#build-form button[type=submit]")
    page.wait_for_selector("#build-progress .stages li.done", timeout=30_000)


def _stages(page, which: str) -> list[str]:
    """The names of the build's stages the page lists (``which``: ``li``, ``li.done``)."""
    items = page.locator(f"#build-progress .stages {which}")
    return items.evaluate_all("items => items.map(i => i.firstChild.textContent)")


def _build_status(page, status: str, timeout: float) -> None:
    page.bring_to_front()
    page.wait_for_selector(f"#build-progress[data-ended='{status}']", timeout=timeout * 1000)


@pytest.fixture(scope="module")
def building(browser, url: str, joined, server):
    """A tab that has started a build (its first stage done), left to run; a say is made
    while it builds. The build is held still (SIGSTOP to its process group) until that say
    is done, so that "while it built" does not depend on which of the two a loaded machine
    happens to finish first."""
    tab = browser.new_page()
    _open(tab, url)
    _build(tab, joined, "s1 here")
    assert tab.is_disabled("#build-form button[type=submit]")  # one build at a time
    shot(tab, "build")
    (build,) = _build_processes()
    os.killpg(build, signal.SIGSTOP)
    try:
        body = json.dumps({"kind": "say", "model": "model", "text": "Said while it builds."})
        status, job = _request(server, "POST", "/api/jobs", body.encode(), X_Miketalk="1",
                               Content_Type="application/json")  # fmt: skip
        assert status == 201, job
        deadline = time.monotonic() + 600  # a poll's generous bound, not a timed assertion
        waiting = ("queued", "running")
        while (doc := _request(server, "GET", f"/api/jobs/{job['id']}")[1])["status"] in waiting:
            if time.monotonic() > deadline:
                break
            time.sleep(0.1)
        assert doc["status"] == "done", doc
    finally:
        os.killpg(build, signal.SIGCONT)
    return tab


def _build_processes() -> list[int]:
    """The pids of the page's build processes (``python -m miketalk.serve.build``) under
    this test process."""
    found, below = [], [os.getpid()]
    while below:
        pid = below.pop()
        with contextlib.suppress(OSError):
            for task in Path(f"/proc/{pid}/task").iterdir():
                below += [int(c) for c in (task / "children").read_text().split()]
            command = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            if pid != os.getpid() and b"miketalk.serve.build" in command:
                found.append(pid)
    return found


def test_the_page_loads_and_lists_the_models(page, url: str) -> None:
    _open(page, url)
    labels = page.locator("#models li .name").all_inner_texts()
    assert labels[0].startswith("model")  # the synthetic face's folder name
    shot(page, "page")
    assert page.errors == []


def test_a_build_shows_its_stages_as_it_runs(building, server) -> None:
    assert _stages(building, "li") == server.app.settings()["build_stages"]
    assert building.locator("#build-progress .stages li.running").count() == 1
    width = building.locator("#build-progress .fill").evaluate("e => e.style.width")
    assert 0 < float(width.rstrip("%")) < 100
    # the server answers while the build works (the build runs in its own process)
    assert building.evaluate("fetch('/api/models').then(r => r.json())")
    assert building.locator("#build-progress .stages li.running").count() == 1  # still


def test_typed_text_plays_with_its_cues_and_downloads(page, url: str, server) -> None:
    _open(page, url)
    labels = page.locator("#models li .name").all_inner_texts()
    assert labels  # (an empty list would check nothing below)
    for label in labels:
        seen = _say(page, label, "Bin blue at F two now, please say it again soon.")
        assert not seen["error"]
        folder = _job_folder(server, seen["job"])
        video, audio = probe_durations(folder / "say.mp4")
        assert abs(seen["duration"] - max(video, audio)) < 0.05, (seen, video, audio)
        assert abs(video - audio) < 0.1
        assert seen["cues"] > 3
        cues = json.loads((folder / "cues.json").read_text())
        assert cues["mouthCues"][-1]["end"] == pytest.approx(audio, abs=0.02)
        assert sorted(p.name for p in folder.iterdir()) == [
            "cues.json", "cues.tsv", "job.json", "say.json", "say.mp4",
        ]  # fmt: skip
        download = page.request.get(seen["mp4"])
        assert download.ok and download.body() == (folder / "say.mp4").read_bytes()
        named = page.get_attribute("#get-mp4", "download")  # not say.mp4: the job's own name
        assert named.startswith(seen["job"] + "-bin-blue-at-f-two-now") and named.endswith(".mp4")
        assert f'filename="{named}"' in download.headers["content-disposition"]
        # announced and focused: not dropped to the body
        assert page.evaluate("document.activeElement.id") == "result-title"
        assert page.inner_text("#announce").startswith("Said: ")
        assert page.get_attribute("#announce", "aria-live") == "polite"
    page.evaluate("document.getElementById('player').pause()")
    shot(page, "played")
    assert page.errors == []


def test_a_second_tab_writes_its_own_folder(browser, page, url: str, server) -> None:
    other = browser.new_page()
    _open(other, url)
    _open(page, url)
    label = page.locator("#models li .name").first.inner_text()
    first, second = _say(page, label, "One."), _say(other, label, "Two.")
    assert first["job"] != second["job"]
    for seen, word in ((first, "One."), (second, "Two.")):
        timeline = json.loads((_job_folder(server, seen["job"]) / "say.json").read_text())
        assert timeline["text"].strip() == word
    other.close()


def test_a_text_file_named_mp4_is_the_librarys_one_line(
    page, url: str, synthetic: Path, tmp_path: Path, monkeypatch, capsys
) -> None:
    fake = tmp_path / "speech.mp4"
    fake.write_text("this is not a video\n")
    _open(page, url)
    page.click("#tab-say")
    page.fill("#say-form textarea[name=text]", "hello")
    page.set_input_files("#say-form input[name=audio]", str(fake))
    assert page.is_disabled("#say-form select[name=voice]")  # the recording speaks
    page.click("#say-form button[type=submit]")
    error = page.locator("#say-form .error")
    error.wait_for(state="visible", timeout=20_000)
    line = error.inner_text()
    shot(page, "error")
    page.set_input_files("#say-form input[name=audio]", [])
    # the command line, with the same file named as the page names it
    monkeypatch.chdir(tmp_path)
    code = cli.main(["say", "--audio", "speech.mp4", "--text", "hello", "--model",
                     str(synthetic), "-o", "out.mp4"])  # fmt: skip
    said = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(said) == 1, said
    assert "\n" not in line and "Traceback" not in line
    assert line.startswith("error: ffmpeg cannot decode the audio of speech.mp4: "), line
    assert line == said[0].replace("miketalk: error: ", "error: ", 1)


def _request(server, method: str, path: str, body: bytes = b"", **headers: str):
    host, port = server.server_address[:2]
    connection = http.client.HTTPConnection(host, port, timeout=30)
    headers = {"Host": f"{host}:{port}"} | {k.replace("_", "-"): v for k, v in headers.items()}
    try:
        connection.request(method, path, body=body or None, headers=headers)
        response = connection.getresponse()
        raw = response.read()
    finally:
        connection.close()
    doc = json.loads(raw) if response.getheader("Content-Type") == "application/json" else raw
    return response.status, doc


def test_a_climbing_file_name_is_only_shown(server, synthetic) -> None:
    results = server.app.config.results
    root = results.parent

    def written() -> set[Path]:  # (the build's work folder comes and goes in models/)
        return {p for p in root.rglob("*") if not {".uploads", "models"} & set(p.parts)}

    before = written()
    names = {}
    for raw in ("../../../../outside.mp4", "..%2F..%2Foutside2.mp4", "..\\..\\outside3.mp4"):
        status, doc = _request(
            server, "POST", "/api/upload?kind=audio", b"not a recording",
            X_Miketalk="1", X_Miketalk_Name=raw,
        )  # fmt: skip
        assert status == 200, doc
        names[doc["name"]] = doc["upload"]
    assert sorted(names) == ["outside.mp4", "outside2.mp4", "outside3.mp4"]
    kept = sorted(p.name for p in (results / ".uploads").iterdir())
    assert kept == sorted(f"{u}.mp4" for u in names.values())
    status, job = _request(
        server, "POST", "/api/jobs", json.dumps({"kind": "say", "model": "model",
        "text": "hello", "audio": names["outside.mp4"]}).encode(),
        X_Miketalk="1", Content_Type="application/json",
    )  # fmt: skip
    assert status == 201, job
    folder = _job_folder(server, job["id"])
    for _ in range(100):
        if (doc := _request(server, "GET", f"/api/jobs/{job['id']}")[1])["status"] == "failed":
            break
        time.sleep(0.1)
    assert doc["message"].startswith("ffmpeg cannot decode the audio of outside.mp4: ")
    assert sorted(p.name for p in folder.iterdir()) == ["job.json", "recording.mp4"]
    after = written()
    assert {p.relative_to(root).parts[:2] for p in after - before} == {("results", job["id"])}
    # files are served from a job's own list only, models chosen from the server's
    assert _request(server, "GET", f"/files/{job['id']}/job.json")[0] == 404
    assert _request(server, "GET", f"/files/{job['id']}/../../job.json")[0] == 404
    bad = {"kind": "say", "model": "../../synthetic", "text": "hello"}
    status, doc = _request(server, "POST", "/api/jobs", json.dumps(bad).encode(),
                           X_Miketalk="1", Content_Type="application/json")  # fmt: skip
    assert status == 400 and doc["error"].startswith("no such model")


def test_refusals_are_one_line(server) -> None:
    job = json.dumps({"kind": "say", "model": "model", "text": "hi"}).encode()
    status, doc = _request(server, "POST", "/api/jobs", job, Content_Type="application/json")
    assert status == 403  # not from the page: no X-Miketalk header
    status, _ = _request(server, "POST", "/api/jobs", job, X_Miketalk="1",
                         Origin="http://evil.example")  # fmt: skip
    assert status == 403
    status, _ = _request(server, "GET", "/api/models", Host="evil.example")
    assert status == 404  # DNS rebinding: another host name
    # over the limit: refused before the body is sent
    status, doc = _request(server, "POST", "/api/upload?kind=video", X_Miketalk="1",
                           X_Miketalk_Name="big.mp4", Content_Length=str(65 << 20))  # fmt: skip
    assert status == 413
    assert doc["error"] == (
        "big.mp4 is 65 MB: larger than the upload limit of 64 MB (miketalk serve --max-upload-mb)"
    )
    for body, said in (
        (b"{", "the request is not JSON"),
        (b'{"kind": "sing"}', "kind must be one of say, dub, build"),
        (b'{"kind": "say", "model": "model"}', "no text: type what the face should say"),
        (b'{"kind": "say", "model": "model", "text": "hi", "lipsync": "learned"}',
         "the model at model has no learned coarticulation"),
        (b'{"kind": "dub", "model": "model", "text": "hi"}',
         "the model model was not built from video of a person"),
        (b'{"kind": "say", "model": "model", "text": "hi", "voice": "bob"}',
         "voice must be one of kal, ked, slt"),
    ):  # fmt: skip
        status, doc = _request(server, "POST", "/api/jobs", body, X_Miketalk="1")
        assert status == 400 and doc["error"].startswith(said), doc
        assert "\n" not in doc["error"]


def test_the_build_ends_with_its_stages_and_a_face_that_speaks(building, server) -> None:
    models = server.app.config.models
    _build_status(building, "done", 600)
    stages = server.app.settings()["build_stages"]
    assert _stages(building, "li.done") == stages
    assert building.locator("#build-progress .fill").evaluate("e => e.style.width") == "100%"
    assert "Built s1 here" in building.locator("#build-progress .outcome").inner_text()
    assert building.locator("#models li[aria-checked='true'] .name").inner_text() == "s1 here"
    jobs = building.evaluate("fetch('/api/jobs').then(r => r.json())")
    build = next(j for j in jobs if j["kind"] == "build")
    assert build["status"] == "done" and [s["name"] for s in build["stages"]] == stages
    (model,) = models.iterdir()  # its own folder, named by the server; no work folder left
    assert model.name == build["id"] and (model / "manifest.json").is_file()
    said = [j["finished"] for j in jobs if j["kind"] == "say" and j["status"] == "done"]
    assert any(build["started"] < t < build["finished"] for t in said)  # while it built
    # its warnings (two clips lack visemes) are on the page, and in the server's log once
    shown = building.locator("#build-progress .warnings li").all_inner_texts()
    assert shown and shown == build["warnings"]
    assert any("has no instance in the training clips" in w for w in shown), shown
    for line in shown:
        assert sum(line in logged for logged in server.logged) == 1, (line, server.logged)
    seen = _say(building, "s1 here", "Bin blue at F two now.")
    assert not seen["error"]
    folder = _job_folder(server, seen["job"])
    assert json.loads((folder / "say.json").read_text())["lipsync_model"] == "learned"
    video, audio = probe_durations(folder / "say.mp4")
    assert abs(seen["duration"] - max(video, audio)) < 0.05
    building.evaluate("document.getElementById('player').pause()")


def test_a_cancelled_build_leaves_nothing(building, joined, server) -> None:
    import multiprocessing

    models = server.app.config.models
    before = sorted(p.name for p in models.iterdir())
    _build(building, joined, "never")
    building.click("#cancel-build")
    _build_status(building, "cancelled", 60)
    assert "no model was written" in building.locator("#build-progress .outcome").inner_text()
    assert sorted(p.name for p in models.iterdir()) == before
    assert not any(p.name.startswith("miketalk-") for p in models.parent.rglob("*"))
    assert multiprocessing.active_children() == []  # the build's process is gone
    assert all(m["label"] != "never" for m in server.app.catalog.describe())
    job = next(j for j in server.app.board.listing() if j["kind"] == "build")
    assert job["status"] == "cancelled" and job["inputs"]["name"] == "never"


def test_a_build_of_another_videos_words_names_the_uploaded_video(
    building, joined, server, tmp_path: Path
) -> None:
    script = tmp_path / "anna's words.txt"
    script.write_text("Elephants juggle marmalade quietly beneath purple umbrellas. " * 3)
    building.bring_to_front()
    building.click("#tab-build")
    building.fill("#build-form input[name=name]", "wrong words")
    building.set_input_files("#build-form input[name=video]", str(joined.video))
    building.set_input_files("#build-form input[name=script]", str(script))
    building.click("#build-form button[type=submit]")
    _build_status(building, "failed", 300)
    line = building.locator("#build-form .error").inner_text()
    assert joined.video.name in line and "video.mp4" not in line, line  # before: video.mp4
    assert line.startswith("error: ") and "\n" not in line


def test_the_command_starts_and_stops(tmp_path: Path) -> None:
    import signal
    import socket
    import subprocess
    import sys

    command = [sys.executable, "-m", "miketalk.cli", "serve", "--port", "0", "--results",
               str(tmp_path / "results"), "--max-upload-mb", "1"]  # fmt: skip
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("miketalk serve: http://127.0.0.1:"), line
        address = line.split("http://")[1].split("/")[0]
        connection = http.client.HTTPConnection(address, timeout=10)
        connection.request("GET", "/api/config")
        assert json.loads(connection.getresponse().read())["max_upload_bytes"] == 1 << 20
        connection.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        err = proc.communicate(timeout=30)[1]
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    with socket.socket() as taken:  # a port in use is one line
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = str(taken.getsockname()[1])
        busy = subprocess.run(
            [*command[:4], "--port", port, "--results", str(tmp_path / "other")],
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
    assert busy.returncode == 2 and busy.stderr.count("\n") == 1, busy.stderr
    assert busy.stderr.startswith(f"miketalk: error: cannot listen on 127.0.0.1:{port}: ")


def test_a_model_kept_open_is_checked_again_when_one_of_its_files_changes(
    synthetic: Path, tmp_path: Path
) -> None:
    import shutil

    from miketalk.api import OpenModels as Warm
    from miketalk.errors import MiketalkError
    from miketalk.flow import pair_path

    model_dir = tmp_path / "model"
    shutil.copytree(synthetic, model_dir)
    warm = Warm(keep=1)
    try:
        model, _ = warm.get(model_dir)
        assert warm.get(model_dir)[0] is model  # kept open while nothing changed
        # a flow no text has read yet, one byte changed (its size kept) while the server runs
        victim = pair_path(model_dir / "flows", "k", "uu")
        data = bytearray(victim.read_bytes())
        data[-20] ^= 0xFF
        victim.unlink()
        victim.write_bytes(bytes(data))
        with pytest.raises(MiketalkError, match=rf"{victim.name} does not match its checksum"):
            warm.get(model_dir)
    finally:
        warm.close()


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` now (``/proc/*/task/*/children``)."""
    found, todo = set(), [pid]
    while todo:
        parent = todo.pop()
        for task in Path(f"/proc/{parent}/task").glob("*"):
            try:
                children = (task / "children").read_text().split()
            except OSError:
                continue
            found.update(map(int, children))
            todo += map(int, children)
    return found


def test_a_stopped_server_ends_a_running_say(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys

    from test_cli import LONG_TEXT, shifted_model
    from test_safety import _alive, _stop

    if not FestivalBackend().is_available():
        pytest.skip("Festival not installed")
    model = shifted_model(tmp_path / "face", 160)  # big enough for a render of some seconds
    results = tmp_path / "results"
    command = [sys.executable, "-m", "miketalk.cli", "serve", "--port", "0", "--results",
               str(results), "--models", str(tmp_path / "models"),
               "--model", str(model)]  # fmt: skip
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        address = proc.stdout.readline().split("http://")[1].split("/")[0]
        connection = http.client.HTTPConnection(address, timeout=30)
        body = json.dumps({"kind": "say", "model": model.name, "text": LONG_TEXT * 2})
        connection.request("POST", "/api/jobs", body, {"X-Miketalk": "1",
                           "Content-Type": "application/json"})  # fmt: skip
        job = json.loads(connection.getresponse().read())
        deadline = time.monotonic() + 120
        encoding = set()
        while not encoding and time.monotonic() < deadline:  # the mp4 being encoded
            time.sleep(0.1)
            encoding = {
                p for p in _descendants(proc.pid)
                if "ffmpeg" in Path(f"/proc/{p}/comm").read_text(errors="replace")
            }  # fmt: skip
        assert encoding, "the say never reached its encoding"
        children = _descendants(proc.pid)
        # before: the server waited for the say to end (13 s for 30 GRID lines on s1); the
        # job's record (interrupted, nothing written) tells it did not
        _stop(proc, signal.SIGTERM, timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        err = proc.communicate(timeout=30)[1]
    assert proc.returncode == 0 and "Traceback" not in err, err
    for _ in range(100):  # killed, or dying with their parent (PR_SET_PDEATHSIG), as in
        if not any(_alive(p) for p in children):  # test_safety: a busy machine may take a
            break  # moment to run a killed process's exit
        time.sleep(0.02)
    assert not [p for p in children if _alive(p)]  # none orphaned
    folder = results / job["id"]
    assert sorted(p.name for p in folder.iterdir()) == ["job.json"]  # nothing half-written
    record = json.loads((folder / "job.json").read_text())
    assert record["status"] == "interrupted" and record["message"].startswith("the server stopped")


def test_a_model_that_is_not_there_is_refused_at_start(tmp_path: Path) -> None:
    import subprocess
    import sys

    (tmp_path / "empty").mkdir()
    for missing in (tmp_path / "nothing", tmp_path / "empty"):
        # before: left out of the list without a word, the server running
        proc = subprocess.run(
            [sys.executable, "-m", "miketalk.cli", "serve", "--port", "0", "--results",
             str(tmp_path / "results"), "--model", str(missing)],
            capture_output=True, text=True, timeout=30,
        )  # fmt: skip
        assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
        assert proc.stderr.startswith(f"miketalk: error: --model {missing}: no model there")


def test_on_a_phone_the_result_is_on_the_screen(browser, url: str) -> None:
    phone = browser.new_page()
    phone.set_viewport_size({"width": 390, "height": 844})
    try:
        _open(phone, url)
        label = phone.locator("#models li .name").first.inner_text()
        _say(phone, label, "Bin blue at F two now.")
        top, height = phone.evaluate(
            "[document.getElementById('result').getBoundingClientRect().top, innerHeight]"
        )
        # scrolled to its top, to within a fraction of a pixel (a layout of fractional line
        # heights lands at -0.09); before: below the fold
        assert -1 < top < height / 2, (top, height)
        shot(phone, "phone")
    finally:
        phone.close()


def test_a_job_is_reached_and_opened_with_the_keyboard(page, url: str) -> None:
    _open(page, url)
    page.wait_for_selector("#jobs li.openable")
    page.focus("#say-form textarea[name=text]")
    for _ in range(80):  # Tab through the page until a job of the list has the focus
        page.keyboard.press("Tab")
        if page.evaluate("document.activeElement.matches('#jobs li.openable')"):
            break
    else:
        raise AssertionError("no job of the list is reached by Tab")
    job_id = page.evaluate("document.activeElement.dataset.id")
    page.evaluate("document.getElementById('player').removeAttribute('data-job')")
    page.keyboard.press("Enter")
    page.wait_for_selector(f"#player[data-job='{job_id}']", state="attached")
    assert not page.is_hidden("#result")


def test_the_text_limit_is_stated_and_a_longer_text_refused_before_any_work(
    page, url: str, server
) -> None:
    _open(page, url)
    words = server.app.settings()["max_text_words"]
    stated = page.inner_text("#say-limit")
    assert f"{words:,} words" in stated and "never cut" in stated  # before any work
    before = len(server.app.board.listing())
    text = "Bin blue at F two now. " * (words // 6 + 1)
    page.fill("#say-form textarea[name=text]", text)
    assert page.input_value("#say-form textarea[name=text]") == text  # pasted whole
    assert "too many" in page.inner_text("#say-limit")
    page.click("#say-form button[type=submit]")
    error = page.locator("#say-form .error")
    error.wait_for(state="visible")
    assert error.inner_text() == (
        f"error: the text has {6 * (words // 6 + 1):,} words: at most {words:,}; nothing was "
        "sent or cut"
    )
    assert len(server.app.board.listing()) == before  # no job
    page.fill("#say-form textarea[name=text]", "")


def test_the_queue_shows_each_jobs_place_and_cancels_a_queued_one(
    page, url: str, server, monkeypatch: pytest.MonkeyPatch
) -> None:
    from miketalk.serve import jobs

    gate, spoken = threading.Event(), jobs.speak

    def held(folder, model_dir, *, text, **more):  # the first job runs until let go
        if text == "Hold on.":
            assert gate.wait(120)
        return spoken(folder, model_dir, text=text, **more)

    monkeypatch.setattr(jobs, "speak", held)
    _open(page, url)
    asked = [
        page.evaluate(
            """async (text) => (await (await fetch('/api/jobs', {method: 'POST',
            headers: {'X-Miketalk': '1', 'Content-Type': 'application/json'},
            body: JSON.stringify({kind: 'say', model: 'model', text})})).json()).id""",
            text,
        )
        for text in ("Hold on.", "One.", "Two.")
    ]
    try:
        page.wait_for_selector(f"#jobs li[data-id='{asked[2]}'] .status:has-text('2nd in line')")
        assert "1st in line" in page.inner_text(f"#jobs li[data-id='{asked[1]}'] .status")
        assert page.inner_text(f"#jobs li[data-id='{asked[0]}'] .status") == "running"
        shot(page, "queue")
        page.click(f"#jobs li[data-id='{asked[1]}'] button.cancel")
        page.wait_for_selector(f"#jobs li[data-id='{asked[1]}'] .status:has-text('cancelled')")
        page.wait_for_selector(f"#jobs li[data-id='{asked[2]}'] .status:has-text('1st in line')")
    finally:
        gate.set()
    assert server.app.board.public(asked[1])["status"] == "cancelled"
    for job_id in (asked[0], asked[2]):
        for _ in range(600):
            if server.app.board.public(job_id)["status"] not in ("queued", "running"):
                break
            time.sleep(0.1)
        assert server.app.board.public(job_id)["status"] == "done"


def test_speak_plays_as_it_is_made_and_stop_ends_it(page, url: str, server) -> None:
    """A long text: its first frame plays while the rest is made (the stream has not ended),
    the viewer's stalls are counted, Stop pauses the video and ends the job, which keeps
    nothing; the times are make bench's (:mod:`miketalk_lab.bench.live_page`)."""
    from test_cli import LONG_TEXT

    _open(page, url)
    page.click("#tab-say")
    _choose(page, "model")
    page.fill("#say-form textarea[name=text]", LONG_TEXT * 4)
    page.click("#say-form button[type=submit]")
    page.wait_for_selector("#player[data-first-frame]", state="attached", timeout=60_000)
    job_id = page.get_attribute("#player", "data-job")
    assert server.app.board.public(job_id)["status"] == "running"  # played while made
    assert page.is_visible("#stop") and page.evaluate("document.activeElement.id") == "stop"
    for _ in range(600):  # (the page's CSP forbids Playwright's evaluated wait_for_function)
        if page.evaluate("() => document.getElementById('player').currentTime > 0.5"):
            break
        time.sleep(0.05)
    shot(page, "live")
    page.click("#stop")
    page.wait_for_selector("#player[data-stop-seconds]", state="attached", timeout=30_000)
    assert page.evaluate("document.getElementById('player').paused")
    job = server.app.board.public(job_id)
    assert job["status"] == "cancelled" and job["stopped_in"] is not None
    assert sorted(p.name for p in _job_folder(server, job_id).iterdir()) == ["job.json"]
    assert page.inner_text("#live-state") == "Stopped: nothing of it was kept."
    assert page.is_hidden("#stop")
    shot(page, "stopped")
