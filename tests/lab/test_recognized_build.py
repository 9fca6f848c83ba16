"""The recognized-build bench's builds: the control cut (the same clips in another order), the
pairing of every build against the first, and its refusal of unknown builds."""

from __future__ import annotations

import pandas as pd
import pytest

from miketalk_lab.bench.recognized_build import main, paired, reordered


def test_the_control_joins_the_same_clips_in_another_order() -> None:
    ids = ["a", "b", "c", "d", "e"]
    assert reordered(ids) == ["d", "e", "a", "b", "c"]
    assert sorted(reordered(ids)) == ids and reordered(ids) != ids
    assert reordered(["a", "b"]) == ["b", "a"]


def test_builds_are_paired_clip_by_clip_against_the_base() -> None:
    base = pd.DataFrame({"renderer": "morph", "clip": ["x", "y", "z"],
                         "lip_opening_amplitude_speech": [1.0, 0.8, 0.9]})  # fmt: skip
    other = base.assign(lip_opening_amplitude_speech=[1.1, 0.9, 1.0]).iloc[::-1]
    (row,) = paired(base, other, ["morph"], ("transcript", "reordered")).to_dict("records")
    assert (row["base"], row["build"], row["clips"]) == ("transcript", "reordered", 3)
    assert row["diff_mean"] == pytest.approx(0.1) and row["diff_sd"] == pytest.approx(0.0)
    assert row["clips_within"] == 0  # each 0.1 off: outside the 0.05 bound


@pytest.mark.parametrize("builds", ["transcript,bogus", "transcript", "transcript,transcript"])
def test_unknown_or_too_few_builds_are_a_usage_error(builds: str, tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--out", str(tmp_path), "--builds", builds])
    assert stop.value.code == 2 and "--builds" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing made
