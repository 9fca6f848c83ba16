"""``dub`` refuses a video of another person (issue 50): dlib's face descriptor distance.

The distances that set :data:`~miketalk.track.identity.MAX_DISTANCE` (s1, the other GRID
talkers, the weekly addresses, mirrored) are measured in docs/dub.md; here, on the committed
clips of s1 only: his own clips and his mirror image lie within it, and the refusal and
``--force`` are wired through ``dub`` (the distance stood in for, the synthetic person having
no face dlib knows).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_dub import _model, _run
from test_stabilize import _clip, _write_video

from miketalk.media.decode import read_video
from miketalk.track import identity
from miketalk.track.identity import MAX_DISTANCE, face_descriptor, person_distance

DATA = Path(__file__).resolve().parents[2] / "data" / "grid_s1" / "video"


def test_his_own_clips_and_his_mirror_image_are_the_same_person(tmp_path):
    reference = read_video(DATA / "bbaf2n.mpg", start=1.0, frames=1)[0][0]
    other = read_video(DATA / "srau3s.mpg", start=1.5, frames=1)[0][0]
    mine, his = face_descriptor(reference), face_descriptor(other)
    assert mine is not None and his is not None and mine.shape == (128,)
    assert np.linalg.norm(mine - his) < MAX_DISTANCE
    mirrored = face_descriptor(np.ascontiguousarray(other[:, ::-1]))
    assert np.linalg.norm(mine - mirrored) < MAX_DISTANCE
    distance = person_distance(reference, DATA / "lgwg2n.mpg")
    assert distance is not None and 0 < distance < MAX_DISTANCE
    blank = np.full_like(reference, 128)  # no face: nothing to compare
    assert face_descriptor(blank) is None and person_distance(blank, DATA / "lgwg2n.mpg") is None


@pytest.fixture(scope="module")
def person(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _model(tmp_path_factory.mktemp("person"), person=True)


def test_dub_refuses_another_person_in_one_line_and_force_goes_on(
    capsys, tmp_path, person, monkeypatch
):
    # the measure is stood in for: no distance another test measured of these bytes is read
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    video = tmp_path / "other.mkv"
    _write_video(video, _clip(30)[0], "25")
    asked = []

    def far(reference, path):
        asked.append(Path(path))
        return MAX_DISTANCE + 0.2

    monkeypatch.setattr(identity, "person_distance", far)
    out = tmp_path / "dub.mp4"
    args = ["dub", str(video), "--text", "Bin blue.", "--model", str(person), "-o", str(out)]
    code, _, err = _run(capsys, *args)
    assert code == 2 and asked == [video] and not out.exists()
    lines = [line for line in err.splitlines() if line.startswith("miketalk: error")]
    assert len(lines) == 1 and "is not the model's person" in lines[0] and "--force" in lines[0]
    assert f"{MAX_DISTANCE + 0.2:.2f}" in lines[0]
    code, _, err = _run(capsys, *args, "--force")
    assert code == 0 and out.exists() and len(asked) == 1  # not asked with --force
