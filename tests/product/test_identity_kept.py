"""The identity check's distance kept in the user's cache (:mod:`miketalk.track.kept_identity`):
a second ``dub`` of the same video with the same model does not look at its faces again, a
damaged entry is measured again, and another person's video is refused before any work on
the second try as on the first.

The synthetic person has no face dlib knows, so dlib's descriptor is stood in for (the
model's reference at the origin, every frame of the video ``far`` from it); everything
else is the product's: the frames are decoded, counted and compared by
:func:`~miketalk.track.identity.person_distance`.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_dub import _model, _run
from test_stabilize import _clip, _write_video

from miketalk.composite import background as background_module
from miketalk.model.face import Model
from miketalk.stabilize.faces import SAMPLES
from miketalk.track import identity, kept_identity
from miketalk.track.identity import MAX_DISTANCE

#: One measure: the reference's descriptor, then one a frame looked at.
MEASURE = 1 + SAMPLES


@pytest.fixture(scope="module")
def person(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _model(tmp_path_factory.mktemp("person"), person=True)


@pytest.fixture
def video(tmp_path: Path) -> Path:
    path = tmp_path / "clip.mkv"
    _write_video(path, _clip(30)[0], "25")
    return path


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    where = tmp_path / "cache"
    monkeypatch.setenv("MIKETALK_CACHE", str(where))
    return where


class Descriptors:
    """dlib's descriptor stood in for: counts its calls; the reference at the origin, any
    other face ``far`` from it."""

    def __init__(self, reference: np.ndarray, far: float) -> None:
        self.reference, self.far, self.calls = reference, far, 0

    def __call__(self, image: np.ndarray, **_) -> np.ndarray:
        self.calls += 1
        found = np.zeros(128)
        if not np.array_equal(image, self.reference):
            found[0] = self.far
        return found


def _descriptors(monkeypatch, person: Path, far: float) -> Descriptors:
    with Model(person) as model:
        reference = np.array(model.reference)
    stand_in = Descriptors(reference, far)
    monkeypatch.setattr(identity, "face_descriptor", stand_in)
    return stand_in


def _dub(capsys, person: Path, video: Path, out: Path) -> tuple[int, str]:
    code, _, err = _run(
        capsys, "dub", str(video), "--text", "Bin blue.", "--model", str(person), "-o", str(out)
    )
    return code, err


def test_a_second_dub_of_the_same_video_does_not_check_again(
    capsys, tmp_path, person, video, cache, monkeypatch
):
    seen = _descriptors(monkeypatch, person, far=0.3)
    code, err = _dub(capsys, person, video, tmp_path / "a.mp4")
    assert code == 0, err
    assert seen.calls == MEASURE  # measured: the reference and each frame looked at
    assert len(list((cache / kept_identity.KIND).glob("*.json"))) == 1
    code, err = _dub(capsys, person, video, tmp_path / "b.mp4")
    assert code == 0, err
    assert seen.calls == MEASURE  # not measured again
    # another video (other bytes) is another entry: measured
    other = tmp_path / "other.mkv"
    _write_video(other, _clip(30)[0][::-1].copy(), "25")
    code, err = _dub(capsys, person, other, tmp_path / "c.mp4")
    assert code == 0, err
    assert seen.calls == 2 * MEASURE


def test_without_a_cache_every_dub_checks(capsys, tmp_path, person, video, monkeypatch):
    monkeypatch.setenv("MIKETALK_CACHE", "off")
    seen = _descriptors(monkeypatch, person, far=0.3)
    for name in ("a.mp4", "b.mp4"):
        code, err = _dub(capsys, person, video, tmp_path / name)
        assert code == 0, err
    assert seen.calls == 2 * MEASURE


@pytest.mark.parametrize("damage", ["not json {", '{"key": 1, "record": 2}', "distance"])
def test_a_damaged_entry_is_checked_again(
    capsys, tmp_path, person, video, cache, monkeypatch, damage
):
    seen = _descriptors(monkeypatch, person, far=0.3)
    assert _dub(capsys, person, video, tmp_path / "a.mp4")[0] == 0
    (entry,) = (cache / kept_identity.KIND).glob("*.json")
    if damage == "distance":  # its own key, a distance no measure gives
        doc = json.loads(entry.read_text())
        doc["record"]["distance"] = "near"
        entry.write_text(json.dumps(doc))
    else:
        entry.write_text(damage)
    assert _dub(capsys, person, video, tmp_path / "b.mp4")[0] == 0
    assert seen.calls == 2 * MEASURE  # measured again
    assert json.loads(entry.read_text())["record"]["distance"] == pytest.approx(0.3)
    assert _dub(capsys, person, video, tmp_path / "c.mp4")[0] == 0
    assert seen.calls == 2 * MEASURE  # and kept again


def test_another_persons_video_is_refused_before_any_work_also_on_the_second_try(
    capsys, tmp_path, person, video, cache, monkeypatch
):
    seen = _descriptors(monkeypatch, person, far=MAX_DISTANCE + 0.2)
    registered = []
    monkeypatch.setattr(
        background_module, "streamed_background", lambda *a, **k: registered.append(a)
    )
    for attempt, name in enumerate(("a.mp4", "b.mp4")):
        out = tmp_path / name
        code, err = _dub(capsys, person, video, out)
        assert code == 2 and not out.exists() and not registered
        lines = [line for line in err.splitlines() if line.startswith("miketalk: error")]
        assert len(lines) == 1 and "is not the model's person" in lines[0], err
        assert f"{MAX_DISTANCE + 0.2:.2f}" in lines[0] and "--force" in lines[0]
        assert seen.calls == MEASURE, attempt  # the second refusal from the kept distance
    assert not list(tmp_path.glob("*.mp4*"))


def test_the_kept_distance_is_named_by_the_reference_and_the_video(tmp_path, cache):
    video = tmp_path / "v.bin"
    video.write_bytes(b"frames")
    reference = np.zeros((4, 4, 3), np.uint8)
    measured = []

    def measure(value):
        def run():
            measured.append(value)
            return value

        return run

    assert kept_identity.kept_distance(reference, video, measure(0.25)) == 0.25
    assert kept_identity.kept_distance(reference, video, measure(0.9)) == 0.25
    other = reference.copy()
    other[0, 0, 0] = 1  # another reference: another entry
    assert kept_identity.kept_distance(other, video, measure(0.9)) == 0.9
    video.write_bytes(b"frames, changed in place")  # other bytes: another entry
    assert kept_identity.kept_distance(reference, video, measure(None)) is None
    assert kept_identity.kept_distance(reference, video, measure(0.5)) is None  # None is kept
    assert measured == [0.25, 0.9, None]
