"""``miketalk serve``'s HTTP side on Starlette and uvicorn, without a browser: the security
headers on every answer, uploads sent chunked (kept whole, or refused over the limit while
they come), ranges and downloads named after their job, a stalled body answered 408, and the
page's messages naming an upload as it was sent, not as the server keeps it.
"""

from __future__ import annotations

import contextlib
import http.client
import json
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from miketalk.serve.guard import SECURITY
from miketalk.speech import FestivalBackend

#: The pages and answers probed for the security headers: the page, its files, JSON, a
#: refusal, a file a job made.
PROBED = ["/", "/static/page.js", "/static/page.css", "/api/config", "/api/models", "/nowhere",
          "/files/nojob/say.mp4"]  # fmt: skip


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from test_cli import shifted_model

    return shifted_model(tmp_path_factory.mktemp("synthetic_face"), 64)


@pytest.fixture(scope="module")
def server(synthetic: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    from miketalk.serve.app import make_server
    from miketalk.serve.config import ServeConfig

    root = tmp_path_factory.mktemp("serve_http")
    config = ServeConfig(
        results=root / "results", models=root / "models", host="127.0.0.1", port=0,
        known_models=(synthetic,), workflow=False, max_upload_bytes=4 << 20, stall_seconds=1,
    )  # fmt: skip
    httpd = make_server(config)
    thread = threading.Thread(target=httpd.serve_forever)
    thread.start()
    yield httpd
    httpd.app.close()
    httpd.shutdown()
    thread.join()
    httpd.server_close()


def _ask(server, method: str, path: str, body=None, **headers: str):
    """``(status, headers, body)`` of one request (an iterable body is sent chunked)."""
    host, port = server.server_address[:2]
    connection = http.client.HTTPConnection(host, port, timeout=30)
    headers = {"Host": f"{host}:{port}"} | {k.replace("_", "-"): v for k, v in headers.items()}
    try:
        connection.request(method, path, body=body, headers=headers)
        response = connection.getresponse()
        return response.status, {k.lower(): v for k, v in response.getheaders()}, response.read()
    finally:
        connection.close()


def _say(server, text: str) -> dict:
    status, _, raw = _ask(server, "POST", "/api/jobs",
                          json.dumps({"kind": "say", "model": "model", "text": text}).encode(),
                          X_Miketalk="1")  # fmt: skip
    assert status == 201, raw
    job = json.loads(raw)
    for _ in range(600):
        job = json.loads(_ask(server, "GET", f"/api/jobs/{job['id']}")[2])
        if job["status"] not in ("queued", "running"):
            return job
        time.sleep(0.1)
    raise AssertionError(f"the say did not end: {job}")


def test_every_answer_carries_the_security_headers(server) -> None:
    seen = {}
    for path in PROBED:
        status, headers, _ = _ask(server, "GET", path)
        seen[path] = status
        for name, value in SECURITY.items():
            assert headers.get(name) == value, (path, name, headers)
        assert "frame-ancestors 'none'" in headers["content-security-policy"]
    assert seen["/nowhere"] == seen["/files/nojob/say.mp4"] == 404
    assert seen["/"] == seen["/api/config"] == 200
    assert SECURITY["cross-origin-resource-policy"] == "same-origin"
    # a refusal of the guard itself (another Host, a POST from elsewhere) carries them too
    for status, headers, _ in (
        _ask(server, "GET", "/api/config", Host="evil.example"),
        _ask(server, "POST", "/api/jobs", b"{}", X_Miketalk="1", Origin="http://evil.example"),
        _ask(server, "POST", "/api/jobs", b"{}", X_Miketalk="1", Sec_Fetch_Site="cross-site"),
    ):
        assert status in (403, 404)
        assert headers["cross-origin-resource-policy"] == "same-origin"


def test_a_chunked_upload_is_kept_whole(server) -> None:
    data = os.urandom(3 << 20)
    pieces = (data[i : i + 100_000] for i in range(0, len(data), 100_000))
    status, _, raw = _ask(server, "POST", "/api/upload?kind=audio", pieces, X_Miketalk="1",
                          X_Miketalk_Name="my%20talk.wav")  # fmt: skip
    doc = json.loads(raw)
    assert status == 200, doc
    assert doc["name"] == "my talk.wav" and doc["size"] == len(data)
    kept = server.app.config.uploads / f"{doc['upload']}.wav"
    assert kept.read_bytes() == data


def _send_until_refused(server, head: bytes, pieces: Iterator[bytes]) -> bytes:
    """Send ``head`` and then ``pieces`` (in a thread) until the server stops taking them;
    its answer."""
    host, port = server.server_address[:2]
    with socket.create_connection((host, port), timeout=30) as sock:
        sock.sendall(head)

        def send() -> None:
            try:
                for piece in pieces:
                    sock.sendall(piece)
            except OSError:  # refused: the server closed the connection
                pass

        sender = threading.Thread(target=send)
        sender.start()
        answer = b""
        try:
            while chunk := sock.recv(65536):
                answer += chunk
        except ConnectionResetError:
            pass
        sender.join(60)
    return answer


def test_a_chunked_upload_over_the_limit_is_refused_as_it_comes(server) -> None:
    uploads = server.app.config.uploads
    before = set(uploads.iterdir())
    host, port = server.server_address[:2]
    head = (f"POST /api/upload?kind=video HTTP/1.1\r\nHost: {host}:{port}\r\nX-Miketalk: 1\r\n"
            "X-Miketalk-Name: big.mp4\r\nTransfer-Encoding: chunked\r\n\r\n").encode()  # fmt: skip
    block = b"\0" * (1 << 18)
    chunk = f"{len(block):x}\r\n".encode() + block + b"\r\n"
    answer = _send_until_refused(server, head, (chunk for _ in range(64)))  # 16 MB of 4 MB
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]
    body = json.loads(answer.split(b"\r\n\r\n", 1)[1])
    assert body["error"] == (
        "big.mp4 is over 4 MB: larger than the upload limit of 4 MB "
        "(miketalk serve --max-upload-mb)"
    )
    assert set(uploads.iterdir()) == before  # nothing of it kept
    assert _ask(server, "GET", "/api/config")[0] == 200


def test_a_stalled_json_body_is_408_and_the_server_answers_on(server) -> None:
    host, port = server.server_address[:2]
    head = (f"POST /api/jobs HTTP/1.1\r\nHost: {host}:{port}\r\nX-Miketalk: 1\r\n"
            "Content-Length: 100\r\n\r\n{\"kind\"").encode()  # fmt: skip
    with socket.create_connection((host, port), timeout=30) as stalled:
        stalled.sendall(head)
        answer = b""
        while chunk := stalled.recv(4096):  # until the server closes it
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 408"), answer[:80]
    assert b"nothing received for 1 s: send it again" in answer
    assert b"500" not in answer.split(b"\r\n")[0]
    assert _ask(server, "GET", "/api/config")[0] == 200


def test_a_video_is_served_in_ranges_and_downloaded_under_the_jobs_name(server) -> None:
    if not FestivalBackend().is_available():
        pytest.skip("Festival not installed")
    job = _say(server, "Bin blue at F two.")
    assert job["status"] == "done", job
    path = server.app.config.results / job["id"] / "say.mp4"
    whole = path.read_bytes()
    status, headers, part = _ask(server, "GET", job["files"]["say.mp4"], Range="bytes=100-1099")
    assert status == 206 and part == whole[100:1100]
    assert headers["content-range"] == f"bytes 100-1099/{len(whole)}"
    assert headers["accept-ranges"] == "bytes"
    status, headers, _ = _ask(server, "GET", job["files"]["say.mp4"], Range=f"bytes={len(whole)}-")
    assert status == 416
    status, headers, body = _ask(server, "GET", job["files"]["say.mp4"] + "?download")
    named = f"{job['id']}-bin-blue-at-f-two.mp4"
    assert status == 200 and body == whole
    assert headers["content-disposition"] == f'attachment; filename="{named}"'
    assert job["downloads"]["say.mp4"] == named
    assert job["downloads"]["cues.json"] == named.replace(".mp4", "-cues.json")
    status, headers, _ = _ask(server, "GET", job["files"]["say.mp4"])  # played: no download
    assert status == 200 and "content-disposition" not in headers


def test_a_message_names_the_upload_as_it_was_sent(server, tmp_path: Path) -> None:
    """The library names a file by its own name alone (``video.mp4``): the page says the
    name the file was uploaded with."""
    from miketalk.serve.records import plainly

    folder = "/srv/results/20261129-110000-build-abcdef/"
    aliases = [(folder, ""), (folder + "video.mp4", "holiday clip.mp4"),
               (folder + "transcript.txt", "what anna says.txt")]  # fmt: skip
    line = ("none of the 9 words can be aligned to the sound of video.mp4: it has no speech; "
            f"see {folder}transcript.txt (not myvideo.mp4 nor video.mp4s)")  # fmt: skip
    assert plainly(line, aliases) == (
        "none of the 9 words can be aligned to the sound of holiday clip.mp4: it has no "
        "speech; see what anna says.txt (not myvideo.mp4 nor video.mp4s)"
    )


def _live_job(server, text: str, model: str = "model") -> dict:
    body = json.dumps({"kind": "say", "model": model, "text": text, "live": True}).encode()
    status, _, raw = _ask(server, "POST", "/api/jobs", body, X_Miketalk="1")
    assert status == 201, raw
    job = json.loads(raw)
    assert job["live"] == f"/api/jobs/{job['id']}/live"
    return job


def _until(server, job_id: str, statuses: set[str], within: float = 120.0) -> dict:
    deadline = time.monotonic() + within
    while (job := json.loads(_ask(server, "GET", f"/api/jobs/{job_id}")[2]))["status"] not in (
        statuses
    ):
        if time.monotonic() > deadline:
            pytest.fail(f"job {job_id} still {job['status']} after {within} s")
        time.sleep(0.05)
    return job


def test_a_live_say_streams_the_frames_its_file_holds(server, tmp_path: Path) -> None:
    """The fragmented MP4 the page plays (read here as it comes, from the job's start) holds
    the very frames of the mp4 the job leaves for download."""
    if not FestivalBackend().is_available():
        pytest.skip("Festival not installed")
    from test_stream import decoded

    job = _live_job(server, "Bin blue at F two now. Place red by G nine soon.")
    host, port = server.server_address[:2]
    connection = http.client.HTTPConnection(host, port, timeout=120)
    connection.request("GET", job["live"], headers={"Host": f"{host}:{port}"})
    response = connection.getresponse()
    assert response.status == 200 and response.getheader("content-type") == "video/mp4"
    pieces = []
    while piece := response.read1(1 << 16):
        pieces.append(piece)
    connection.close()
    assert len(pieces) > 1  # it came in pieces, as made
    (tmp_path / "live.mp4").write_bytes(b"".join(pieces))
    done = _until(server, job["id"], {"done", "failed"})
    assert done["status"] == "done", done
    folder = server.app.config.results / job["id"]
    assert sorted(p.name for p in folder.iterdir()) == [
        "cues.json", "cues.tsv", "job.json", "say.json", "say.mp4",
    ]  # fmt: skip
    frames = decoded(folder / "say.mp4", "v")
    assert len(frames) == done["result"]["frames"] > 30 and len(set(frames)) > 5
    assert decoded(tmp_path / "live.mp4", "v") == frames
    timeline = json.loads((folder / "say.json").read_text())
    assert len(timeline["frames"]) == len(frames)
    # written as it was encoded, the text json.dumps gives
    assert (folder / "say.json").read_text() == json.dumps(timeline, indent=1)
    cues = json.loads((folder / "cues.json").read_text())
    assert cues["mouthCues"][-1]["end"] == pytest.approx(done["result"]["duration"], abs=0.02)
    # once ended, a late reader gets nothing more: the job's file is its download
    assert _ask(server, "GET", job["live"])[2] == b""


def test_a_long_timeline_is_written_without_its_whole_text_in_memory(tmp_path: Path) -> None:
    """A live job's timeline JSON (an hour's: 108,000 frames, 30 MB of text) is written as
    it is encoded: json.dumps held every piece of the text in a list before joining them."""
    import tracemalloc

    from miketalk.serve.work import write_text

    frames = [{"index": i, "time": i / 30, "transition": i // 4, "alpha": 0.5,
               "samples": [[i // 4, 0.25, 0.5], [i // 4 + 1, 0.0, 0.5]]}
              for i in range(20_000)]  # fmt: skip
    doc = {"text": "bin blue at f two now", "frames": frames}
    text = json.dumps(doc, indent=1)
    tracemalloc.start()
    write_text(tmp_path / "say.json", doc)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert (tmp_path / "say.json").read_text() == text
    assert len(text) > 4_000_000 and peak < len(text) / 20
    assert [p.name for p in tmp_path.iterdir()] == ["say.json"]


def test_a_stop_ends_a_running_live_say_and_its_processes(server) -> None:
    if not FestivalBackend().is_available():
        pytest.skip("Festival not installed")
    from test_cli import LONG_TEXT
    from test_stream import descendants

    def tools() -> set[int]:
        names = {}
        for pid in descendants():
            with contextlib.suppress(OSError):
                names[pid] = Path(f"/proc/{pid}/comm").read_text().strip()
        return {p for p, n in names.items() if n.startswith(("ffmpeg", "festival"))}

    before = tools()
    job = _live_job(server, LONG_TEXT * 4)
    host, port = server.server_address[:2]
    connection = http.client.HTTPConnection(host, port, timeout=120)
    connection.request("GET", job["live"], headers={"Host": f"{host}:{port}"})
    response = connection.getresponse()
    assert response.read1(1 << 16)  # playing: its first fragment came
    working = tools() - before
    assert working, "no ffmpeg or Festival seen at work"
    status, _, raw = _ask(server, "POST", f"/api/jobs/{job['id']}/cancel", X_Miketalk="1")
    assert status == 200, raw
    while response.read1(1 << 16):  # the stream ends
        pass
    connection.close()
    ended = _until(server, job["id"], {"cancelled", "done", "failed"}, within=30)
    assert ended["status"] == "cancelled", ended
    assert ended["message"] == "stopped: nothing of it was kept"
    assert isinstance(ended["stopped_in"], float)  # its time: make bench (live_page)
    assert not (working & tools())  # every process of its work ended
    folder = server.app.config.results / job["id"]
    assert sorted(p.name for p in folder.iterdir()) == ["job.json"]
    # the server goes on: the next live say plays whole
    assert _until(server, _live_job(server, "One.")["id"], {"done", "failed"})["status"] == "done"


def test_the_text_limit_is_the_librarys() -> None:
    from miketalk.serve.config import MAX_TEXT_WORDS
    from miketalk.speech.text import MAX_SPOKEN_WORDS

    assert MAX_TEXT_WORDS == MAX_SPOKEN_WORDS


def test_a_text_over_the_word_limit_is_refused_before_it_is_queued(server) -> None:
    from miketalk.serve.config import MAX_TEXT_WORDS

    before = len(server.app.board.listing())
    text = "word " * (MAX_TEXT_WORDS + 1)
    body = json.dumps({"kind": "say", "model": "model", "text": text, "live": True}).encode()
    status, _, raw = _ask(server, "POST", "/api/jobs", body, X_Miketalk="1")
    assert status == 400
    assert json.loads(raw)["error"] == (
        f"the text has {MAX_TEXT_WORDS + 1:,} words: at most {MAX_TEXT_WORDS:,} (some 60 "
        "minutes of speech); split it"
    )
    assert len(server.app.board.listing()) == before


#: A committed GRID clip of s1 (3 s of video with his speech).
CLIP = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"


def _upload(server, path: Path, kind: str) -> str:
    status, _, raw = _ask(server, "POST", f"/api/upload?kind={kind}", path.read_bytes(),
                          X_Miketalk="1", X_Miketalk_Name=path.name)  # fmt: skip
    assert status == 200, raw
    return json.loads(raw)["upload"]


def _job(server, body: dict) -> tuple[int, dict]:
    status, _, raw = _ask(server, "POST", "/api/jobs", json.dumps(body).encode(), X_Miketalk="1")
    return status, json.loads(raw)


def test_the_page_builds_from_a_video_alone_its_words_to_be_recognized(server) -> None:
    """Issue 53 item 4: Build a face with no transcript or subtitles is a build job whose
    words the library recognizes (``api.build`` with neither); cancelled here, at once."""
    status, job = _job(server, {"kind": "build", "name": "no words",
                                "video": _upload(server, CLIP, "video")})  # fmt: skip
    assert status == 201, job
    assert job["inputs"]["words"] == "recognized from its speech"
    assert server.app.board.get(job["id"]).params["script"] == {}
    _ask(server, "POST", f"/api/jobs/{job['id']}/cancel", X_Miketalk="1")
    ended = _until(server, job["id"], {"cancelled", "failed", "done"}, within=60)
    assert ended["status"] == "cancelled", ended
    assert not (server.app.config.models / job["id"]).exists()


def test_the_page_speaks_a_recording_given_without_its_text(server) -> None:
    """Issue 53 item 4: a recording with no text is spoken with the words recognized from
    it (``api.say`` of a ``Recorded`` without text), as ``miketalk say --audio`` does."""
    status, job = _job(server, {"kind": "say", "model": "model", "text": "",
                                "audio": _upload(server, CLIP, "audio")})  # fmt: skip
    assert status == 201, job
    assert job["inputs"]["words"] == "recognized from its speech" and not job["inputs"]["text"]
    done = _until(server, job["id"], {"done", "failed"})
    assert done["status"] == "done", done
    timeline = json.loads((server.app.config.results / job["id"] / "say.json").read_text())
    assert timeline["words_from"].startswith("whisper-base")
    assert "two now" in timeline["text"].lower()  # bbaf2n says "bin blue at f two now"


def test_the_page_dubs_with_the_videos_own_model_when_none_is_chosen(server, monkeypatch) -> None:
    """Issue 53 item 4: a dub with no face of the list asks the library for the video's own
    model (``api.own_model``: built once, kept by the video's checksum) and dubs with it; a
    say still needs a face. The build itself (minutes) is test_dub's; here the library's call
    is watched, and the model it gives is the synthetic face, which a dub refuses."""
    from miketalk import api

    asked = []

    def own_model(video, **kwargs):
        asked.append(Path(video))
        return server.app.catalog.get("model").path, False

    monkeypatch.setattr(api, "own_model", own_model)
    body = {"kind": "dub", "text": "Bin blue.", "video": _upload(server, CLIP, "video")}
    status, job = _job(server, body)
    assert status == 201, job
    assert job["inputs"]["model"] == "the video's own"
    ended = _until(server, job["id"], {"done", "failed"})
    assert [p.name for p in asked] == ["video.mpg"]
    assert asked[0].parent == server.app.config.results / job["id"]  # the uploaded video
    assert ended["status"] == "failed" and "person" in ended["message"], ended
    status, refused = _job(server, {"kind": "say", "text": "Bin blue."})
    assert status == 400 and asked == [asked[0]], refused
