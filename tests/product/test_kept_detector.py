"""dlib's frontal face detector kept in the user's cache (miketalk.stabilize.kept_detector):
read back from it, the same detector as dlib's own; a damaged entry is made again."""

from __future__ import annotations

import pickle

import dlib
import pytest

from miketalk.stabilize.kept_detector import KIND, frontal_face_detector


@pytest.fixture(scope="module")
def dlibs_own() -> bytes:
    return pickle.dumps(dlib.get_frontal_face_detector())


def _not_made(*_a, **_k):
    raise AssertionError("made by dlib: the kept one was not read")


def test_the_detector_is_kept_and_read_back_the_same(tmp_path, monkeypatch, dlibs_own) -> None:
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path))
    assert pickle.dumps(frontal_face_detector()) == dlibs_own
    kept = list((tmp_path / KIND).glob("*.svm"))
    assert len(kept) == 1 and list((tmp_path / KIND).glob("*.json"))
    monkeypatch.setattr(dlib, "get_frontal_face_detector", _not_made)
    assert pickle.dumps(frontal_face_detector()) == dlibs_own


def test_a_damaged_entry_is_made_again(tmp_path, monkeypatch, dlibs_own) -> None:
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path))
    frontal_face_detector()
    (kept,) = (tmp_path / KIND).glob("*.svm")
    good = kept.read_bytes()
    kept.write_bytes(good[: len(good) // 2])  # cut short: its digest no longer matches
    assert pickle.dumps(frontal_face_detector()) == dlibs_own
    assert kept.read_bytes() == good
    assert not [p for p in (tmp_path / KIND).iterdir() if p.name.startswith(".")]


def test_without_a_cache_dlib_makes_it(tmp_path, monkeypatch, dlibs_own) -> None:
    monkeypatch.setenv("MIKETALK_CACHE", "off")
    monkeypatch.chdir(tmp_path)
    assert pickle.dumps(frontal_face_detector()) == dlibs_own
    assert not list(tmp_path.rglob("*.svm"))


def test_the_stabilizers_and_the_judges_detector_is_the_kept_one(tmp_path, monkeypatch, dlibs_own):
    """A one-video build's face check and the held-out evaluation's landmark judge read the
    kept detector too (dlib's own parse: 0.3 to 0.6 s of CPU in each of their processes)."""
    from miketalk.stabilize.faces import _detector
    from miketalk_lab.evaluation.landmarks import FaceLandmarks

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path))
    frontal_face_detector()
    monkeypatch.setattr(dlib, "get_frontal_face_detector", _not_made)
    assert pickle.dumps(_detector()) == dlibs_own
    assert pickle.dumps(FaceLandmarks()._detector) == dlibs_own
