"""The flow database (OpenEXR pair files), .flo files and the endpoint-error metric."""

from __future__ import annotations

import json

import numpy as np
import OpenEXR
import pytest

from miketalk.errors import MiketalkError
from miketalk.flow import (
    FlowDatabase,
    pair_filename,
    pair_path,
    read_flo,
    read_flow_pair,
    write_flo,
    write_flow_pair,
)
from miketalk.visemes import VISEMES, viseme_slug
from miketalk_lab.evaluation.flow_error import endpoint_error


def _flows(shape=(24, 32), seed=0):
    rng = np.random.default_rng(seed)
    forward = (rng.standard_normal((*shape, 2)) * 5).astype(np.float32)
    backward = (rng.standard_normal((*shape, 2)) * 5).astype(np.float32)
    # values that a lossy or half-float path would change
    forward[0, 0] = (np.float32(1.0) + np.finfo(np.float32).eps, np.float32(-3.4e38))
    backward[-1, -1] = (np.float32(1e-40), np.float32(7.0000005))  # a denormal
    return forward, backward


def test_exr_round_trip_is_bit_identical_with_header(tmp_path):
    forward, backward = _flows()
    settings = {"levels": np.int64(6), "window": 3.0, "preset": None}
    path = write_flow_pair(
        tmp_path / "pair.exr",
        forward,
        backward,
        source="w-au",
        target="#",
        estimator="bergen",
        settings=settings,
    )
    pair = read_flow_pair(path)
    assert pair.forward.dtype == np.float32 and pair.backward.dtype == np.float32
    assert pair.forward.tobytes() == forward.tobytes()
    assert pair.backward.tobytes() == backward.tobytes()
    assert (pair.source, pair.target, pair.estimator) == ("w-au", "#", "bergen")
    assert pair.settings == {"levels": 6, "window": 3.0, "preset": None}
    assert pair.valid_forward is None and pair.valid_backward is None
    # the layout other tools see: 32-bit float channels forward.u/v, backward.u/v
    exr = OpenEXR.File(str(path), separate_channels=True)
    channels = exr.channels()
    assert sorted(channels) == ["backward.u", "backward.v", "forward.u", "forward.v"]
    assert all(ch.pixels.dtype == np.float32 for ch in channels.values())
    header = exr.header()
    assert header["miketalk.source"] == "w-au" and header["miketalk.target"] == "#"
    assert json.loads(header["miketalk.settings"])["levels"] == 6
    assert list(tmp_path.iterdir()) == [path]  # no temporary left behind


def test_exr_valid_channels_round_trip(tmp_path):
    forward, backward = _flows()
    valid_f = np.zeros(forward.shape[:2], bool)
    valid_f[3:, 5:] = True
    valid_b = ~valid_f
    path = write_flow_pair(
        tmp_path / "gt.exr",
        forward,
        backward,
        source="p",
        target="ii",
        estimator="ground_truth",
        valid=(valid_f, valid_b),
    )
    pair = read_flow_pair(path)
    np.testing.assert_array_equal(pair.valid_forward, valid_f)
    np.testing.assert_array_equal(pair.valid_backward, valid_b)
    assert "forward.valid" in OpenEXR.File(str(path), separate_channels=True).channels()


def test_exr_writer_rejects_bad_flows(tmp_path):
    forward, backward = _flows()
    bad = forward.copy()
    bad[1, 1, 0] = np.nan
    with pytest.raises(MiketalkError, match=r"forward.*NaN"):
        write_flow_pair(tmp_path / "x.exr", bad, backward, source="a", target="b", estimator="e")
    with pytest.raises(MiketalkError, match=r"backward"):
        write_flow_pair(
            tmp_path / "x.exr", forward, backward[:-1], source="a", target="b", estimator="e"
        )
    assert not list(tmp_path.iterdir())


def test_missing_and_corrupt_exr_name_the_file(tmp_path):
    missing = tmp_path / "nope.exr"
    with pytest.raises(MiketalkError, match=r"nope.exr"):
        read_flow_pair(missing)
    corrupt = tmp_path / "corrupt.exr"
    corrupt.write_bytes(b"not an exr file at all" * 10)
    with pytest.raises(MiketalkError, match=r"corrupt.exr"):
        read_flow_pair(corrupt)
    forward, backward = _flows()
    good = write_flow_pair(
        tmp_path / "good.exr", forward, backward, source="a", target="b", estimator="e"
    )
    truncated = tmp_path / "truncated.exr"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(MiketalkError, match=r"truncated.exr"):
        read_flow_pair(truncated)
    # an EXR that is not a flow pair: channel missing
    other = tmp_path / "rgb.exr"
    pixels = np.zeros((4, 4), np.float32)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION}, {"R": pixels}).write(str(other))
    with pytest.raises(MiketalkError, match=r"rgb.exr.*miketalk.source"):
        read_flow_pair(other)


def test_nan_in_a_stored_flow_is_refused(tmp_path):
    forward, backward = _flows()
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "miketalk.source": "a",
        "miketalk.target": "b",
        "miketalk.estimator": "e",
        "miketalk.settings": "{}",
    }
    backward[2, 2, 1] = np.inf
    channels = {
        "forward.u": forward[..., 0].copy(),
        "forward.v": forward[..., 1].copy(),
        "backward.u": backward[..., 0].copy(),
        "backward.v": backward[..., 1].copy(),
    }
    path = tmp_path / "nan.exr"
    OpenEXR.File(header, channels).write(str(path))
    with pytest.raises(MiketalkError, match=r"nan.exr.*backward.*NaN or inf"):
        read_flow_pair(path)


def test_slugs_are_safe_and_one_to_one():
    names = [*VISEMES, "@", "ou:1", "A", "a", "_", "-x", "x-", "é"]
    slugs = [viseme_slug(n) for n in names]
    assert len(set(slugs)) == len(slugs)
    for s in slugs:
        assert set(s) <= set("abcdefghijklmnopqrstuvwxyz0123456789_-")
        assert "__" not in s and not s.startswith("-")
    assert viseme_slug("#") == "_23" and viseme_slug("w-au") == "w-au" and viseme_slug("@") == "_40"
    files = {pair_filename(a, b) for i, a in enumerate(VISEMES) for b in VISEMES[i + 1 :]}
    assert len(files) == 16 * 15 // 2
    assert pair_filename("#", "p") == pair_filename("p", "#") == "_23__p.exr"
    with pytest.raises(MiketalkError, match=r"two different"):
        pair_filename("p", "p")


def test_database_picks_the_layer_by_direction(tmp_path):
    forward, backward = _flows()
    write_flow_pair(
        pair_path(tmp_path, "w-au", "#"),
        forward,
        backward,
        source="w-au",
        target="#",
        estimator="bergen",
    )
    db = FlowDatabase(tmp_path)
    np.testing.assert_array_equal(db.flow("w-au", "#"), forward)
    np.testing.assert_array_equal(db.flow("#", "w-au"), backward)
    assert db.flow("w-au", "#") is db.flow("w-au", "#")  # cached
    assert not db.flow("#", "w-au").flags.writeable
    np.testing.assert_array_equal(db.flow("#", "#"), np.zeros_like(forward))
    assert db.valid("w-au", "#") is None
    with pytest.raises(MiketalkError, match=pair_filename("p", "ii")):
        db.flow("p", "ii")


def test_database_refuses_a_file_under_another_pairs_name(tmp_path):
    forward, backward = _flows()
    write_flow_pair(
        pair_path(tmp_path, "p", "ii"), forward, backward, source="p", target="t", estimator="e"
    )
    with pytest.raises(MiketalkError, match=r"renamed"):
        FlowDatabase(tmp_path).flow("ii", "p")
    with pytest.raises(MiketalkError, match=r"does not exist"):
        FlowDatabase(tmp_path / "missing")


def test_flo_round_trip(tmp_path):
    forward, _ = _flows((5, 7))
    path = write_flo(tmp_path / "f.flo", forward)
    data = path.read_bytes()
    assert np.frombuffer(data[:4], "<f4")[0] == np.float32(202021.25)
    assert data[:4] == b"PIEH"
    assert tuple(np.frombuffer(data[4:12], "<i4")) == (7, 5)
    back = read_flo(path)
    assert back.dtype == np.float32 and back.tobytes() == forward.tobytes()
    (tmp_path / "bad.flo").write_bytes(data[:-4])
    with pytest.raises(MiketalkError, match=r"bad.flo"):
        read_flo(tmp_path / "bad.flo")
    (tmp_path / "magic.flo").write_bytes(b"XXXX" + data[4:])
    with pytest.raises(MiketalkError, match=r"magic.flo.*magic"):
        read_flo(tmp_path / "magic.flo")
    with pytest.raises(MiketalkError, match=r"none.flo"):
        read_flo(tmp_path / "none.flo")


def test_endpoint_error_summaries():
    true_flow = np.zeros((2, 3, 2), np.float32)
    flow = true_flow.copy()
    flow[0, 0] = (3.0, 4.0)  # error 5
    flow[0, 1] = (0.0, 2.0)  # error 2
    flow[0, 2] = (0.0, 1.0)  # error 1, not "over 1"
    scores = endpoint_error(flow, true_flow)
    assert scores["mean_epe"] == pytest.approx(8 / 6)
    assert scores["pct_over_1px"] == pytest.approx(100 * 2 / 6)
    assert scores["pct_over_3px"] == pytest.approx(100 * 1 / 6)
    assert scores["pixels"] == 6
    mask = np.zeros((2, 3), bool)
    mask[0, 1] = True
    assert endpoint_error(flow, true_flow, mask)["mean_epe"] == pytest.approx(2.0)
    true_flow[1, 2] = np.inf  # unknown ground truth is left out by default
    assert endpoint_error(flow, true_flow)["pixels"] == 5
    with pytest.raises(MiketalkError, match=r"no pixels"):
        endpoint_error(flow, true_flow, np.zeros((2, 3), bool))
