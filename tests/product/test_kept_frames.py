"""Image files decoded once and kept decoded in the user's cache (a model's background)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from miketalk.media import kept_frames as kept
from miketalk.media.frame_source import ImageFrames
from miketalk.media.images import write_png
from miketalk.media.yuv import to_i420


def _frames(tmp_path: Path, n: int = 5, size: tuple[int, int] = (24, 32)) -> list[Path]:
    rng = np.random.default_rng(1)
    paths = []
    for i in range(n):
        paths.append(tmp_path / "frames" / f"{i:04d}.png")
        paths[-1].parent.mkdir(exist_ok=True)
        write_png(paths[-1], rng.integers(0, 256, (*size, 3), np.uint8))
    return paths


def test_frames_are_decoded_once_and_read_from_the_cache_after(tmp_path, monkeypatch):
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    paths = _frames(tmp_path)
    truth = [ImageFrames(paths)[i] for i in range(len(paths))]
    reads: list[int] = []
    read_file = ImageFrames.read_file
    monkeypatch.setattr(ImageFrames, "read_file", lambda s, i: reads.append(i) or read_file(s, i))
    first = kept.kept_frames(paths)
    assert sorted(reads) == list(range(len(paths)))
    second = kept.kept_frames(paths)
    assert sorted(reads) == list(range(len(paths)))  # nothing decoded again
    for found in (first, second):
        assert isinstance(found, kept.KeptFrames) and isinstance(found.rgb, np.memmap)
        assert not found.rgb.flags.writeable
        assert all(np.array_equal(found.rgb[i], t) for i, t in enumerate(truth))
        assert all(np.array_equal(found.i420[i], to_i420(t)) for i, t in enumerate(truth))


def test_another_identity_a_damaged_entry_or_no_cache_decode_the_files(tmp_path, monkeypatch):
    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    paths = _frames(tmp_path, size=(23, 32))  # odd: no I420
    found = kept.kept_frames(paths, identity=["a"] * len(paths))
    assert isinstance(found, kept.KeptFrames) and found.i420 is None
    entries = sorted((tmp_path / "cache" / kept.KIND).glob("*.npy"))
    assert len(entries) == 1
    kept.kept_frames(paths, identity=["b"] * len(paths))  # other files: another entry
    assert len(list((tmp_path / "cache" / kept.KIND).glob("*.npy"))) == 2
    entries[0].write_bytes(entries[0].read_bytes()[:-10])  # cut short: made again
    again = kept.kept_frames(paths, identity=["a"] * len(paths))
    assert isinstance(again, kept.KeptFrames)
    assert np.array_equal(again.rgb[-1], ImageFrames(paths)[len(paths) - 1])
    monkeypatch.setenv("MIKETALK_CACHE", "off")
    assert isinstance(kept.kept_frames(paths), ImageFrames)


def test_a_file_that_cannot_be_decoded_is_an_error_and_nothing_is_kept(tmp_path, monkeypatch):
    from miketalk.errors import MiketalkError

    monkeypatch.setenv("MIKETALK_CACHE", str(tmp_path / "cache"))
    paths = _frames(tmp_path)
    paths[3].write_bytes(b"not a png")
    with pytest.raises(MiketalkError, match=r"0003\.png"):
        kept.kept_frames(paths)
    assert not list((tmp_path / "cache" / kept.KIND).iterdir())
