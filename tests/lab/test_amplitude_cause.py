"""The amplitude-cause bench's parts: one build's phones given to another's frames through the
joined video (exactly its own when given its own), the planned opening and its spread, the
pairing, and its refusal of a refit of unknown builds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from miketalk_lab.bench.amplitude_cause import main, opening_map, paired, planned_opening, spread
from miketalk_lab.bench.relabelled import clip_phones, joined_phones, relabelled


def _corpus(folder: Path, firsts: dict[str, int], phones: dict[str, list]) -> Path:
    """A corpus folder's ``sources.tsv`` and ``phones.tsv`` (clip times), 25 fps."""
    folder.mkdir()
    pd.DataFrame(
        [{"clip": c, "media": "joined.mp4", "first_frame": f, "frames": 50, "fps": 25.0}
         for c, f in firsts.items()]
    ).to_csv(folder / "sources.tsv", sep="\t", index=False)  # fmt: skip
    rows = [
        {"clip": c, "index": k, "phone": n, "start": a, "end": b, "clip_start": a, "clip_end": b}
        for c, own in phones.items()
        for k, (n, a, b) in enumerate(own)
    ]
    pd.DataFrame(rows).to_csv(folder / "phones.tsv", sep="\t", index=False)
    (folder / "audio.wav").write_bytes(b"")  # linked, not read
    return folder


TRANSCRIPT = {
    "u1": [("pau", 0.0, 0.4), ("b", 0.4, 0.5), ("ih", 0.5, 0.6), ("n", 0.6, 0.7),
           ("uw", 0.7, 1.0), ("pau", 1.0, 2.0)],
    "u2": [("pau", 0.0, 0.5), ("s", 0.5, 0.7), ("eh", 0.7, 0.9), ("t", 0.9, 1.0),
           ("pau", 1.0, 2.0)],
}  # fmt: skip


def _read(folder: Path) -> pd.DataFrame:
    return pd.read_csv(folder / "phones.tsv", sep="\t", dtype={"clip": str})


def test_a_corpus_given_its_own_phones_keeps_them_exactly(tmp_path) -> None:
    corpus = _corpus(tmp_path / "t", {"u1": 10, "u2": 70}, TRANSCRIPT)
    start, end, name = joined_phones(corpus)[1]
    assert (start, end, name) == (pytest.approx(0.8), pytest.approx(0.9), "b")  # 10/25 + 0.4
    out = _read(relabelled(corpus, corpus, tmp_path / "again"))
    before = _read(corpus)
    assert list(out["phone"]) == list(before["phone"])
    assert np.allclose(out["clip_start"], before["clip_start"])
    assert np.allclose(out["clip_end"], before["clip_end"])
    assert (tmp_path / "again" / "audio.wav").is_symlink()


def test_another_builds_phones_are_read_through_the_joined_video(tmp_path) -> None:
    ours = _corpus(tmp_path / "t", {"u1": 10, "u2": 70}, TRANSCRIPT)
    # the other build's first clip starts 5 frames (0.2 s) later and lost "bin" to a pause
    theirs = _corpus(tmp_path / "r", {"u1": 15, "u2": 70},
                     {"u1": [("pau", 0.0, 0.5), ("uw", 0.5, 0.8), ("pau", 0.8, 1.8)],
                      "u2": TRANSCRIPT["u2"]})  # fmt: skip
    out = _read(relabelled(ours, theirs, tmp_path / "mixed"))
    u1 = out[out["clip"] == "u1"]
    assert list(u1["phone"]) == ["pau", "uw", "pau"]
    assert u1["clip_start"].tolist() == pytest.approx([0.0, 0.7, 1.0])  # 0.2 s later in theirs
    assert u1["clip_end"].iloc[-1] == pytest.approx(2.0)  # the clip's own end, pau filled
    shifted = _read(relabelled(ours, ours, tmp_path / "late", shift=0.04))
    b = shifted[(shifted["clip"] == "u1") & (shifted["phone"] == "b")].iloc[0]
    assert (b["clip_start"], b["clip_end"]) == (pytest.approx(0.44), pytest.approx(0.54))


def test_windows_take_the_other_phones_only_inside_them() -> None:
    ours = [(0.0, 0.4, "pau"), (0.4, 0.5, "b"), (0.5, 0.6, "ih"), (0.6, 1.0, "uw")]
    theirs = [(0.0, 0.55, "pau"), (0.55, 1.0, "uw")]
    inside = clip_phones(ours, theirs, 0.0, 1.0, windows=[(0.3, 0.58)])
    # theirs in the window (their pau joined to ours before it, their uw), ours after it
    assert [n for *_, n in inside] == ["pau", "uw", "ih", "uw"]
    assert [a for a, *_ in inside] == pytest.approx([0.0, 0.55, 0.58, 0.6])
    outside = clip_phones(ours, theirs, 0.0, 1.0, windows=[(0.8, 0.9)])
    assert [n for *_, n in outside] == ["pau", "b", "ih", "uw"]  # uw cut and joined again
    assert outside[-1][:2] == (pytest.approx(0.6), pytest.approx(1.0))


def test_the_planned_opening_and_its_spread() -> None:
    opening = np.array([0.0, 2.0, 4.0, 10.0])
    rows = [((0, 1.0),), ((1, 0.85), (2, 0.15)), ((3, 1.0),)]
    assert planned_opening(rows, opening) == pytest.approx([0.0, 2.3, 10.0])
    real = np.array([5.0, 1.0, 3.0, 9.0])
    values = 2.0 * real
    assert spread(values, real, slice(1, 4)) == pytest.approx(2.0)
    assert np.isnan(spread(values, np.ones(4), slice(0, 4)))
    coords = np.random.default_rng(0).normal(size=(50, 3))
    beta, fit = opening_map(coords, coords @ [1.0, -2.0, 0.5] + 3.0)
    assert beta == pytest.approx([1.0, -2.0, 0.5, 3.0]) and fit == pytest.approx(1.0)


def test_faces_are_paired_clip_by_clip_against_the_base() -> None:
    base = pd.DataFrame({"face": "transcript", "clip": ["x", "y"], "measured": [0.9, 1.0],
                         "trajectory": 0.7, "target": 1.1, "drawn": [0.9, 1.0],
                         "drawn_no_gain": 0.7, "drawn_all_gain": 1.0})  # fmt: skip
    other = base.assign(face="recognized", drawn=[1.0, 1.1]).iloc[::-1]
    table = paired(pd.concat([base, other]), "transcript").set_index("figure")
    assert table.loc["drawn", "diff_mean"] == pytest.approx(0.1)
    assert table.loc["drawn", "diff_sd"] == pytest.approx(0.0)
    assert table.loc["measured", "diff_mean"] == pytest.approx(0.0)


@pytest.mark.parametrize(
    "extra",
    [
        [],
        ["--build", "a"],
        ["--build", "a=x", "--refit", "a:b"],
        ["--build", "a=x", "--without-unsure", "b"],
        ["--build", "a=x", "--window", "2,1"],
        ["--build", "a=x", "--with-unsure", "b"],
        ["--build", "a=x", "--trained", "f=b:nowhere"],
        ["--build", "a=x", "--trained", "f=a:nowhere"],  # no face in the folder
    ],
)
def test_bad_arguments_are_a_usage_error(extra, tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--out", str(tmp_path / "out"), *extra])
    assert stop.value.code == 2 and "--" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # nothing made
