"""Two runs' held-out tables paired (miketalk_lab.bench.paired_runs)."""

from __future__ import annotations

import pandas as pd
import pytest

from miketalk_lab.bench.paired_runs import MEASURES, equal_renderers, paired_table


def _table(shift: float) -> pd.DataFrame:
    rows = []
    for i, clip in enumerate(["a", "b", "c"]):
        for renderer in ("morph", "learned"):
            moved = shift * (i + 1) if renderer == "learned" else 0.0
            rows.append({"clip": clip, "renderer": renderer, "model": "m"}
                        | {m: 1.0 + i + moved for m in MEASURES})  # fmt: skip
    return pd.DataFrame(rows)


def test_only_the_renderer_that_moved_differs_and_its_difference_is_paired() -> None:
    before, after = _table(0.0), _table(0.1)
    assert equal_renderers(before, after) == {"learned": pytest.approx(0.3), "morph": 0.0}
    table = paired_table(before, after, "learned").set_index("measure")
    assert table.loc["mouth_lmd", "clips"] == 3
    assert table.loc["mouth_lmd", "diff_mean"] == pytest.approx(0.2)  # 0.1, 0.2, 0.3
    assert table.loc["mouth_lmd", "diff_low"] < 0.2 < table.loc["mouth_lmd", "diff_high"]
    with pytest.raises(ValueError, match="different clips"):
        equal_renderers(before, after[after["clip"] != "c"])
