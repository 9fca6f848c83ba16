"""The model on disk, the say pipeline, and their errors (a tiny model of noise textures)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.flow import get_estimator, pair_path, write_flow_pair
from miketalk.media.images import write_png
from miketalk.model.face import Model
from miketalk.model.write import build_model
from miketalk.speech import FestivalBackend, Phone
from miketalk.visemes import VISEMES

needs_festival = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival not installed"
)


def texture(seed: int, size: int = 48) -> np.ndarray:
    rng = np.random.default_rng(seed)
    noise = rng.random((size // 4, size // 4, 3))
    image = cv2.resize(noise, (size, size), interpolation=cv2.INTER_CUBIC)
    return np.clip(image * 255, 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """All 16 visemes: shifted copies of one texture, flows by our estimator."""
    root = tmp_path_factory.mktemp("model")
    base = texture(0, 64)
    images, paths = {}, {}
    for i, v in enumerate(VISEMES):
        shifted = np.roll(base, (i % 4) - 2, axis=1)[8:56, 8:56]
        images[v] = np.ascontiguousarray(shifted)
        paths[v] = root / "src" / f"{i}.png"
        paths[v].parent.mkdir(exist_ok=True)
        write_png(paths[v], images[v])
    estimate = get_estimator("bergen", levels=2)
    flows = root / "flows"
    flows.mkdir()
    for i, a in enumerate(VISEMES):
        for b in VISEMES[i + 1 :]:
            write_flow_pair(
                pair_path(flows, a, b),
                estimate(images[a], images[b]),
                estimate(images[b], images[a]),
                source=a,
                target=b,
                estimator="bergen",
                settings={"levels": 2},
            )
    return build_model(
        root / "model", images=paths, flows_dir=flows, estimator="bergen", settings={}
    )


def test_model_loads_and_morphs(model_dir: Path) -> None:
    model = Model(model_dir)
    assert model.visemes == VISEMES and model.size == (48, 48)
    assert model.displacement("p", "p") == 0.0
    assert 0 < model.displacement("p", "f") < 5
    assert np.array_equal(model.frame("p", "f", 0.0), model.image("p"))
    assert np.array_equal(model.frame("p", "f", 1.0), model.image("f"))
    middle = model.frame("p", "f", 0.5)
    assert middle.shape == (48, 48, 3) and middle.dtype == np.uint8


def test_model_applies_morph_options_and_renders_what_it_prefetches(model_dir: Path) -> None:
    from miketalk.render.morph import Morpher

    plain = Model(model_dir, morph_options={"median": False})
    flows = plain.flows
    expected = Morpher(
        plain.image("p"), plain.image("aa"), flows.flow("p", "aa"), flows.flow("aa", "p"),
        median=False,
    ).frame(0.4)  # fmt: skip
    assert np.array_equal(plain.frame("p", "aa", 0.4), expected)
    assert not np.array_equal(Model(model_dir).frame("p", "aa", 0.4), expected)
    ahead = Model(model_dir)
    ahead.prefetch([("f", "aa"), ("aa", "f")])
    assert np.array_equal(ahead.frame("f", "aa", 0.3), Model(model_dir).frame("f", "aa", 0.3))


def test_model_errors(model_dir: Path, tmp_path: Path) -> None:
    with pytest.raises(MiketalkError, match="no model"):
        Model(tmp_path / "nothing")
    broken = tmp_path / "broken"
    shutil.copytree(model_dir, broken)
    manifest = json.loads((broken / "manifest.json").read_text())
    manifest["size"] = [50, 50]
    (broken / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(MiketalkError, match="the manifest says 50x50"):
        Model(broken)
    missing = tmp_path / "missing"
    shutil.copytree(model_dir, missing)
    next((missing / "flows").glob("*.exr")).unlink()
    with pytest.raises(MiketalkError, match="is missing"):
        Model(missing)
    corrupt = tmp_path / "corrupt"
    shutil.copytree(model_dir, corrupt)
    victim = pair_path(corrupt / "flows", "p", "f")
    victim.write_bytes(victim.read_bytes()[:100])
    with pytest.raises(MiketalkError, match=victim.name):
        Model(corrupt).frame("p", "f", 0.5)
    with pytest.raises(MiketalkError, match="no viseme 'zz'"):
        Model(model_dir).image("zz")


@needs_festival
def test_say_writes_mp4_and_timeline(model_dir: Path, tmp_path: Path) -> None:
    from miketalk.lipsync.settings import LipsyncSettings
    from miketalk.media.video import probe_durations
    from miketalk.talk.say import say

    out = tmp_path / "hello.mp4"
    spoken = say("Hello world", out, model=Model(model_dir), settings=LipsyncSettings(fps=30))
    utterance, timeline = spoken.utterance, spoken.timeline
    video_s, audio_s = probe_durations(out)
    assert abs(video_s - audio_s) <= 1 / 30
    assert abs(len(timeline.frames) / 30 - utterance.duration) <= 1 / 30
    doc = json.loads(out.with_suffix(".json").read_text())
    assert doc["largest_step_px"] <= 2.5 + 1e-6
    assert len(doc["frames"]) == len(timeline.frames)


@needs_festival
def test_say_bad_input_leaves_nothing(model_dir: Path, tmp_path: Path) -> None:
    from miketalk.talk.say import say

    out = tmp_path / "empty.mp4"
    with pytest.raises(MiketalkError, match="nothing to speak"):
        say("  ?! ", out, model=Model(model_dir))
    assert list(tmp_path.iterdir()) == []


@needs_festival
def test_cli_say_errors_are_one_line(model_dir: Path, tmp_path: Path) -> None:
    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "miketalk.cli", "say", *args],
            capture_output=True,
            text=True,
            cwd=tmp_path,
        )

    missing = run("Hello", "-o", "x.mp4", "--model", str(tmp_path / "none"))
    assert missing.returncode == 2 and "no model at" in missing.stderr
    assert "Traceback" not in missing.stderr
    empty = run("", "-o", "x.mp4", "--model", str(model_dir))
    assert empty.returncode == 2 and "nothing to speak" in empty.stderr
    ok = run("Hi there.", "-o", "hi.mp4", "--model", str(model_dir))
    assert ok.returncode == 0, ok.stderr
    assert (tmp_path / "hi.mp4").exists() and (tmp_path / "hi.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hi.json", "hi.mp4"]


def test_a_blurred_frame_is_the_weighted_mean_of_its_morphs(model_dir: Path) -> None:
    from miketalk.lipsync import timeline as lipsync
    from miketalk.visemes import default_table

    phones = [Phone("pau", 0.0, 0.1), Phone("f", 0.1, 0.2), Phone("aa", 0.2, 0.3)]
    timeline = lipsync.plan(phones, default_table(), fps=30.0, duration=0.3)
    model = Model(model_dir)
    samples = ((1, 0.25, 0.5), (1, 0.75, 0.25), (2, 0.5, 0.25))
    t1, t2 = timeline.transitions[1], timeline.transitions[2]
    expected = (
        0.5 * model.frame(t1.source, t1.target, 0.25).astype(float)
        + 0.25 * model.frame(t1.source, t1.target, 0.75)
        + 0.25 * model.frame(t2.source, t2.target, 0.5)
    )
    got = model.exposure(timeline, samples)
    assert got.dtype == np.uint8 and np.abs(got - expected).max() <= 0.5 + 1e-3


def test_render_gives_the_same_bytes_with_any_number_of_workers(model_dir: Path) -> None:
    from miketalk.lipsync import sampling
    from miketalk.lipsync import timeline as lipsync
    from miketalk.visemes import default_table

    phones = [
        Phone(n, 0.06 * i, 0.06 * (i + 1)) for i, n in enumerate("pau b ae t f ay pau".split())
    ]
    point = lipsync.plan(phones, default_table(), fps=30.0, duration=phones[-1].end)
    blurred = sampling.motion_blur(
        point, displacement=lambda a, b: 0.0 if a == b else 12.0, max_px_per_frame=0.5
    )
    assert blurred.morph_count > 2 * len(blurred.frames)
    with Model(model_dir) as one, Model(model_dir) as two:
        serial = list(one.render(blurred, workers=1))
        parallel = list(two.render(blurred, workers=2))
    assert len(serial) == len(blurred.frames)
    assert all(np.array_equal(a, b) for a, b in zip(serial, parallel, strict=True))
    plain = list(Model(model_dir).render(point, workers=1))
    assert any(not np.array_equal(a, b) for a, b in zip(plain, serial, strict=True))


def test_manifest_paths_stay_inside_the_model(model_dir: Path, tmp_path: Path) -> None:
    from miketalk.model.manifest import inside

    assert inside(model_dir, "visemes/p.png", "x") == model_dir / "visemes" / "p.png"
    for bad in ("../x.png", "/etc/passwd", "visemes/../../x", "..\\x", "C:/x.png", "a/../../b"):
        with pytest.raises(MiketalkError, match="outside the model directory"):
            inside(model_dir, bad, "the image")
    escaped = tmp_path / "escaped"
    shutil.copytree(model_dir, escaped)
    manifest = json.loads((escaped / "manifest.json").read_text())
    manifest["images"]["p"] = "../../etc/passwd"
    (escaped / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(MiketalkError, match="outside the model directory"):
        Model(escaped)


def test_a_model_opened_again_unchanged_is_not_hashed_again_and_a_change_is_found(
    model_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The checksums of a model's files are checked once per unchanged model in a process
    (live speech opens models often); a file changed since, or a model written less than
    ``SETTLED_NS`` before its check, is hashed again."""
    from miketalk.model import manifest

    directory = tmp_path / "model"
    shutil.copytree(model_dir, directory)
    hashed: list[Path] = []
    digest = manifest.file_digest
    monkeypatch.setattr(manifest, "file_digest", lambda p: hashed.append(p) or digest(p))
    monkeypatch.setattr(manifest, "_CHECKED", {})
    listed = len(json.loads((directory / "manifest.json").read_text())["files"])
    Model(directory).close()
    Model(directory).close()
    assert len(hashed) == 2 * listed  # just written: not settled, hashed at every open
    monkeypatch.setattr(manifest, "SETTLED_NS", 0)
    hashed.clear()
    Model(directory).close()
    assert len(hashed) == listed
    with Model(directory) as again:
        assert len(hashed) == listed and not again.changed_on_disk()
    image = directory / "visemes" / "aa.png"
    data = bytearray(image.read_bytes())
    data[-20] ^= 0xFF  # the same size, another checksum
    image.write_bytes(bytes(data))
    stat = image.stat()
    os.utime(image, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))  # a later time, surely
    with pytest.raises(MiketalkError, match=r"aa\.png does not match its checksum"):
        Model(directory)


def test_a_check_passed_in_one_run_is_not_repeated_by_the_next_and_a_change_is_found(
    model_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The record of a passed check outlives the process (the user's cache): a new run
    opening the same unchanged model hashes nothing; a file changed since (the same size,
    another checksum), or a record from another manifest, is checked again and refused."""
    from miketalk.model import manifest

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    directory = tmp_path / "model"
    shutil.copytree(model_dir, directory)
    hashed: list[Path] = []
    digest = manifest.file_digest
    monkeypatch.setattr(manifest, "file_digest", lambda p: hashed.append(p) or digest(p))
    monkeypatch.setattr(manifest, "SETTLED_NS", 0)
    listed = len(json.loads((directory / "manifest.json").read_text())["files"])
    monkeypatch.setattr(manifest, "_CHECKED", {})
    Model(directory).close()
    assert len(hashed) == listed
    assert len(list((tmp_path / "cache" / manifest.RECORDS).glob("*.json"))) == 1
    monkeypatch.setattr(manifest, "_CHECKED", {})  # a new run: only the record is left
    Model(directory).close()
    assert len(hashed) == listed
    monkeypatch.setenv("MIKETALK_CACHE", "off")  # nothing kept: hashed at every run
    monkeypatch.setattr(manifest, "_CHECKED", {})
    Model(directory).close()
    assert len(hashed) == 2 * listed
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    image = directory / "visemes" / "aa.png"
    data = bytearray(image.read_bytes())
    data[-20] ^= 0xFF
    image.write_bytes(bytes(data))
    monkeypatch.setattr(manifest, "_CHECKED", {})
    with pytest.raises(MiketalkError, match=r"aa\.png does not match its checksum"):
        Model(directory)


def test_a_manifest_validated_once_is_not_validated_again_and_a_changed_one_is(
    model_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A manifest's text that passed the schema is recorded in the user's cache: the next
    open of the same text does not validate it again (no jsonschema); another text is
    validated, and refused when it does not pass."""
    from miketalk.model import manifest

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    validated: list[int] = []
    validator = manifest._manifest_validator
    monkeypatch.setattr(manifest, "_manifest_validator", lambda: validated.append(1) or validator())
    first = manifest.read_manifest(model_dir)
    assert len(validated) == 1
    assert manifest.read_manifest(model_dir) == first and len(validated) == 1  # recorded
    monkeypatch.setenv("MIKETALK_CACHE", "off")  # nothing kept: validated at every open
    manifest.read_manifest(model_dir)
    assert len(validated) == 2
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    directory = tmp_path / "model"
    shutil.copytree(model_dir, directory)
    bad = json.loads((directory / "manifest.json").read_text()) | {"visemes": "p"}
    (directory / "manifest.json").write_text(json.dumps(bad))
    for _ in range(2):  # a text that failed is never recorded: refused again
        with pytest.raises(MiketalkError, match="at visemes, 'p' is not of type 'array'"):
            manifest.read_manifest(directory)
    assert len(validated) == 4


def test_a_models_flows_are_kept_decoded_for_the_next_run_and_give_the_same_frames(
    model_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The flows a model reads are kept decoded in the user's cache, named by their file's
    size and SHA-256 in the manifest: the next run reads no flow file, and morphs the same
    bytes; another file (another checksum) is read from itself."""
    from miketalk.flow import FlowDatabase

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    read: list[tuple[str, str]] = []
    flow = FlowDatabase.flow
    monkeypatch.setattr(FlowDatabase, "flow", lambda s, a, b: read.append((a, b)) or flow(s, a, b))
    with Model(model_dir) as first:
        drawn = [first.frame("p", "aa", alpha) for alpha in (0.25, 0.5)]
        assert first.flow_identity("p", "aa") is not None
    assert read
    read.clear()
    with Model(model_dir) as again:
        again_drawn = [again.frame("p", "aa", alpha) for alpha in (0.25, 0.5)]
    assert all(np.array_equal(a, b) for a, b in zip(again_drawn, drawn, strict=True))
    assert read == []  # nothing read from the flow file
    monkeypatch.setattr(Model, "flow_identity", lambda self, a, b: ("another", a, b))
    with Model(model_dir) as other:
        other.frame("p", "aa", 0.5)
    assert read
