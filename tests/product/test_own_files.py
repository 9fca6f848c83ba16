"""Nothing of the user's lost (issue 50, items 1, 2, 3, 8): ``build --force`` replaces only a
model's own files, ``cues`` only the files it wrote as they are, a model's files are read
(and served) only when they are its own regular files, and the smaller corners: the build's
lock before its work, miketalk's own TextGrid as word timings, a full disk while ffmpeg
encodes, ``sub/../`` in ``-o``, an upload that stops coming."""

from __future__ import annotations

import http.client
import json
import logging
import shutil
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from miketalk import cli
from miketalk.errors import MiketalkError
from miketalk.media.ownership import Kind, check_replaceable, foreign_entry, written_by_miketalk

ROOT = Path(__file__).resolve().parents[2]
CLIP = ROOT / "data" / "grid_s1" / "video" / "bbaf2n.mpg"


@pytest.fixture(scope="module")
def face(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from test_cli import shifted_model

    return shifted_model(tmp_path_factory.mktemp("face"), 64)


def _copy(model: Path, where: Path) -> Path:
    shutil.copytree(model, where / "model")
    return where / "model"


def _tree(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _one_line(capsys: pytest.CaptureFixture[str], *fragments: str) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    for fragment in fragments:
        assert fragment in err[0], err[0]
    return err[0]


# ---------------------------------------------------------------------------
# build --force: only a model's own files
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("users", ["my_notes.txt", "my_stuff/talk.mp4"])
def test_build_force_refuses_a_model_folder_holding_the_users_files(
    face: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], users: str
) -> None:
    model = _copy(face, tmp_path)
    (model / users).parent.mkdir(parents=True, exist_ok=True)
    (model / users).write_bytes(b"mine")
    (tmp_path / "t.txt").write_text("bin blue at f two now\n")
    before = _tree(tmp_path)
    args = ["build", str(CLIP), "--transcript", str(tmp_path / "t.txt"), "-o", str(model)]
    assert cli.main([*args, "--force"]) == 2
    _one_line(capsys, f"holds {users}, which its manifest does not name", "--force replaces only")
    assert _tree(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model", "t.txt"]  # no lock, no work


def test_a_models_own_files_are_told_from_anything_else(face: Path, tmp_path: Path) -> None:
    model = _copy(face, tmp_path)
    assert foreign_entry(model) is None
    check_replaceable(model, Kind.MODEL, force=True)  # its own files only: replaced
    (model / "my_stuff").mkdir()
    assert foreign_entry(model) == "my_stuff/"  # an empty folder of the user's
    (model / "my_stuff" / "talk.mp4").write_bytes(b"mine")
    assert foreign_entry(model) == "my_stuff/talk.mp4"
    shutil.rmtree(model / "my_stuff")
    (model / ".hidden").write_text("mine")
    assert foreign_entry(model) == ".hidden"
    (model / ".hidden").unlink()
    flow = next((model / "flows").iterdir())
    flow.rename(tmp_path / "away.exr")
    flow.symlink_to(tmp_path / "away.exr")  # a link where its file was: not its own
    assert foreign_entry(model) == flow.relative_to(model).as_posix()
    flow.unlink()
    manifest = json.loads((model / "manifest.json").read_text())
    del manifest["files"]
    (model / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(MiketalkError, match="whose manifest does not list its files"):
        check_replaceable(model, Kind.MODEL, force=True)


@pytest.mark.slow
def test_a_built_model_names_all_its_files_with_its_record(s1_built: Path) -> None:
    from miketalk.media.ownership import model_files
    from miketalk.model.face import Model

    own = model_files(s1_built)
    assert own is not None and {"build/segments.json", "build/clips.tsv"} <= own
    assert foreign_entry(s1_built) is None
    Model(s1_built).close()  # the record is checked with the rest when it opens


def test_a_second_build_of_one_model_is_refused_before_its_work(
    s1_joined, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The model's lock is checked first and taken before the work, held to its end: another
    build of the same folder (here: the lock held by this test) is refused before its inputs
    are checked, and no stage runs."""
    import fcntl

    from miketalk.building.from_video import build_model_from_video
    from miketalk.corpus import one_video
    from miketalk.media.atomic import lock_path, output_lock

    stages: list[str] = []

    def segment(*args, **kwargs) -> None:
        lock = lock_path(tmp_path / "m")
        fd = lock.open("rb")
        try:
            with pytest.raises(BlockingIOError):  # its own build holds it while it works
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            fd.close()
        stages.append("segment")
        raise MiketalkError("stopped here by the test")

    real_check = one_video.check_video_inputs

    def check_inputs(*args, **kwargs):
        stages.append("inputs")
        return real_check(*args, **kwargs)

    monkeypatch.setattr(one_video, "segment_video", segment)
    monkeypatch.setattr(one_video, "check_video_inputs", check_inputs)
    script = {"transcript": s1_joined.transcript, "progress": False}
    with output_lock(tmp_path / "m"):  # another build of m runs
        with pytest.raises(MiketalkError, match=r"another miketalk is writing .*m now"):
            build_model_from_video(s1_joined.video, tmp_path / "m", **script)
    assert stages == []  # refused before its inputs were even checked
    with pytest.raises(MiketalkError, match="stopped here by the test"):
        build_model_from_video(s1_joined.video, tmp_path / "m", **script)
    assert stages == ["inputs", "segment"]
    assert list(tmp_path.iterdir()) == []  # its lock and work folder gone


# ---------------------------------------------------------------------------
# cues: only the files it wrote, as it wrote them
# ---------------------------------------------------------------------------

#: What a user may keep under each name: Rhubarb's own output, a TextGrid of another tool.
_THEIRS = {
    "c.json": '{\n  "metadata": {\n    "soundFile": "a.wav",\n    "duration": 0.50\n  },\n'
    '  "mouthCues": [\n    { "start": 0.00, "end": 0.50, "value": "X" }\n  ]\n}\n',
    "c.tsv": "0.00\tX\n0.20\tB\n0.50\tX\n",
    "c.TextGrid": 'File type = "ooTextFile"\nObject class = "TextGrid"\n\nxmin = 0\nxmax = 1\n'
    'tiers? <exists>\nsize = 3\nitem []:\n    item [1]:\n        class = "IntervalTier"\n'
    '        name = "phones"\n        xmin = 0\n        xmax = 1\n        intervals: size = 0\n'
    '    item [2]:\n        class = "IntervalTier"\n        name = "visemes"\n'
    "        xmin = 0\n        xmax = 1\n        intervals: size = 0\n    item [3]:\n"
    '        class = "TextTier"\n        name = "keyframes"\n        xmin = 0\n'
    "        xmax = 1\n        points: size = 0\n",
}


@pytest.mark.parametrize("name", list(_THEIRS))
def test_cues_replace_only_what_miketalk_wrote_as_it_wrote_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    from miketalk.speech import FestivalBackend

    if not FestivalBackend().is_available():
        pytest.skip("Festival not installed")
    monkeypatch.chdir(tmp_path)
    path = tmp_path / name
    # a file in Rhubarb's (or miketalk's) own format that miketalk did not write
    path.write_text(_THEIRS[name])
    assert cli.main(["cues", "hello there", "-o", name]) == 2
    _one_line(capsys, f"{name} exists and is not", "miketalk wrote, unchanged since", "--force")
    assert path.read_text() == _THEIRS[name]
    # with --force it is replaced, and from then on it is miketalk's (its record beside it)
    assert cli.main(["cues", "hello there", "-o", name, "--force"]) == 0
    assert written_by_miketalk(path, next(k for k in Kind if k.value in _kind(name)))
    assert cli.main(["cues", "hello world", "-o", name]) == 0
    capsys.readouterr()
    # tuned by hand afterwards: the user's again
    tuned = path.read_text().replace("X", "A", 1).replace("hh", "HH", 1)
    assert tuned != path.read_text()
    path.write_text(tuned)
    assert cli.main(["cues", "hello there", "-o", name]) == 2
    _one_line(capsys, f"{name} exists and is not")
    assert path.read_text() == tuned
    # its record copied beside another file names another file: not a way in
    (tmp_path / f".x{Path(name).suffix}.miketalk.json").write_text(
        (tmp_path / f".{name}.miketalk.json").read_text()
    )
    shutil.copyfile(path, tmp_path / f"x{Path(name).suffix}")
    assert not written_by_miketalk(tmp_path / f"x{Path(name).suffix}", Kind.CUES_JSON)


def _kind(name: str) -> str:
    return {".json": "cues-json", ".tsv": "cues-tsv", ".TextGrid": "textgrid"}[Path(name).suffix]


def test_miketalks_own_textgrid_is_not_read_as_word_timings(tmp_path: Path) -> None:
    from praatio import textgrid as tg
    from praatio.utilities.constants import Interval

    from miketalk.speech.word_timings import read_word_timings

    own = tmp_path / "own.TextGrid"
    own.write_text(_THEIRS["c.TextGrid"])
    with pytest.raises(MiketalkError, match=r"no tier named words \(its interval tiers: phones"):
        read_word_timings(own)
    grid = tg.Textgrid(0.0, 1.0)
    grid.addTier(tg.IntervalTier("phones", [Interval(0.1, 0.3, "hh")], 0.0, 1.0))
    grid.addTier(tg.IntervalTier("Words", [Interval(0.1, 0.6, "hello")], 0.0, 1.0))
    grid.save(str(tmp_path / "two.TextGrid"), format="long_textgrid", includeBlankSpaces=True)
    assert [w.word for w in read_word_timings(tmp_path / "two.TextGrid")] == ["hello"]
    grid = tg.Textgrid(0.0, 1.0)
    grid.addTier(tg.IntervalTier("mine", [Interval(0.1, 0.6, "hello")], 0.0, 1.0))
    grid.save(str(tmp_path / "one.TextGrid"), format="long_textgrid", includeBlankSpaces=True)
    assert [w.word for w in read_word_timings(tmp_path / "one.TextGrid")] == ["hello"]


# ---------------------------------------------------------------------------
# a model's files: its own regular files, links resolved
# ---------------------------------------------------------------------------


def test_a_flow_linked_out_of_the_model_is_never_read(face: Path, tmp_path: Path) -> None:
    from miketalk.model.face import Model

    model = _copy(face, tmp_path)
    flow = sorted((model / "flows").iterdir())[0]
    shutil.copyfile(flow, tmp_path / "same_bytes.exr")
    flow.unlink()
    flow.symlink_to(tmp_path / "same_bytes.exr")  # its very bytes, outside the folder
    with pytest.raises(MiketalkError, match=r"is a link to a file outside the model directory"):
        Model(model)
    flow.unlink()
    flow.symlink_to(Path("/etc/passwd"))
    with pytest.raises(MiketalkError, match=r"is a link to a file outside the model directory"):
        Model(model)
    flow.unlink()
    shutil.copyfile(tmp_path / "same_bytes.exr", flow)
    Model(model).close()
    # a link inside the folder to its own file is read
    image = model / "visemes" / sorted(p.name for p in (model / "visemes").iterdir())[0]
    image.rename(model / "kept.png")
    image.symlink_to("../kept.png")
    Model(model).close()


@pytest.fixture()
def served(face: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator:
    """A server of a copy of the face with a picture, on a free port, stalls cut at 1 s."""
    from miketalk.serve import app as serve_app
    from miketalk.serve.config import ServeConfig

    model = _copy(face, tmp_path)
    config = ServeConfig(
        results=tmp_path / "results", models=tmp_path / "models", host="127.0.0.1", port=0,
        known_models=(model,), workflow=False, max_upload_bytes=200 << 20, stall_seconds=1,
    )  # fmt: skip
    httpd = serve_app.make_server(config)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.1})
    thread.start()
    yield httpd, model
    httpd.shutdown()
    thread.join()
    httpd.server_close()
    httpd.app.close()


def _get(httpd, path: str) -> tuple[int, bytes]:
    host, port = httpd.server_address[:2]
    connection = http.client.HTTPConnection(host, port, timeout=30)
    try:
        connection.request("GET", path, headers={"Host": f"{host}:{port}"})
        response = connection.getresponse()
        return response.status, response.read()
    finally:
        connection.close()


def test_the_page_serves_only_the_models_own_picture(served) -> None:
    httpd, model = served
    status, listed = _get(httpd, "/api/models")
    doc = json.loads(listed)
    model_id = (doc["models"] if isinstance(doc, dict) else doc)[0]["id"]
    rest = json.loads((model / "manifest.json").read_text())["images"]["#"]
    assert _get(httpd, f"/api/models/{model_id}/image") == (200, (model / rest).read_bytes())
    (model / "background").mkdir()
    (model / "background" / "0000.png").symlink_to("/etc/passwd")
    status, body = _get(httpd, f"/api/models/{model_id}/image")
    assert status == 404 and b"root" not in body
    shutil.rmtree(model / "background")
    rest_path = model / rest  # the rest viseme linked out: no picture either
    rest_path.rename(model.parent / "outside.png")
    rest_path.symlink_to(model.parent / "outside.png")
    assert _get(httpd, f"/api/models/{model_id}/image")[0] == 404


# ---------------------------------------------------------------------------
# the smaller corners
# ---------------------------------------------------------------------------


def test_an_upload_that_stops_coming_is_answered_and_let_go(
    served, caplog: pytest.LogCaptureFixture
) -> None:
    """100 MB declared, 3 bytes sent: after the handler's timeout (1 s here, 60 s in use)
    the client gets 408 and the connection is closed; a client that leaves mid-upload is let
    go without a traceback; no partial upload is kept; the server still answers."""
    httpd, _ = served
    host, port = httpd.server_address[:2]
    head = (
        f"POST /api/upload?kind=video HTTP/1.1\r\nHost: {host}:{port}\r\nX-Miketalk: 1\r\n"
        f"X-Miketalk-Name: a.mp4\r\nContent-Length: {100 << 20}\r\n\r\nabc"
    ).encode()
    caplog.set_level(logging.DEBUG, logger="miketalk.serve")
    with socket.create_connection((host, port)) as stalled:
        stalled.sendall(head)
        stalled.settimeout(30)
        answer = b""
        while chunk := stalled.recv(4096):  # until the server closes it
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 408"), answer[:80]
    assert b"nothing received for 1 s" in answer
    with socket.create_connection((host, port)) as leaving:
        leaving.sendall(head)
    assert _get(httpd, "/api/config")[0] == 200
    assert not [r for r in caplog.records if r.exc_info or r.levelno >= logging.ERROR]
    uploads = httpd.app.config.uploads
    for _ in range(200):  # the server learns that the second client left as its loop goes on
        if not uploads.exists() or not any(uploads.iterdir()):
            break
        time.sleep(0.05)
    assert not any(uploads.iterdir()) if uploads.exists() else True


def test_a_full_disk_while_ffmpeg_encodes_is_exit_one_and_one_line(
    face: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """Injected: an ffmpeg that fails as the real one does on a full disk (its log, taken
    from a 2 MB tmpfs; docs/safety.md); the disk itself is not filled."""
    from miketalk.media import encoder, video

    fake = tmp_path / "ffmpeg"
    fake.write_text(
        "#!/bin/sh\ncat > /dev/null\n"
        "echo '[vost#0:0/libx264 @ 0x5630] Error submitting a packet to the muxer: "
        "No space left on device' >&2\n"
        "echo '[out#0/mp4 @ 0x5630] Error writing trailer: No space left on device' >&2\n"
        "exit 228\n"
    )
    fake.chmod(0o755)
    for module in (video, encoder):  # the file's writer and the stream's encoder
        monkeypatch.setattr(module, "ffmpeg_exe", lambda: str(fake))
    out = tmp_path / "out" / "v.mp4"
    assert cli.main(["say", "Hi.", "--model", str(face), "-o", str(out)]) == 1
    _one_line(capsys, "No space left on device", "nothing was written")
    assert not out.parent.exists() or not any(out.parent.iterdir())
    fake.write_text("#!/bin/sh\ncat > /dev/null\necho 'x264 [error]: malloc failed' >&2\nexit 1\n")
    assert cli.main(["say", "Hi.", "--model", str(face), "-o", str(out)]) == 2
    _one_line(capsys, "ffmpeg failed encoding the video: x264 [error]: malloc failed")


def test_a_dot_dot_after_a_missing_folder_is_refused_and_leaves_nothing(
    face: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    monkeypatch.chdir(tmp_path)
    assert cli.main(["say", "Hi.", "--model", str(face), "-o", "./sub/../talk.mp4"]) == 2
    _one_line(capsys, "there is no folder sub for its '..'")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "sub").mkdir()  # a folder that is there: the path is the system's to resolve
    assert cli.main(["say", "Hi.", "--model", str(face), "-o", "./sub/../talk.mp4"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sub", "talk.json", "talk.mp4"]
