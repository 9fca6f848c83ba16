"""Tests of miketalk_lab.bench.dub_detail: a softer drawn mouth scores lower."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from miketalk.media.video import write_mp4
from miketalk_lab.bench.dub_detail import changed_box, main


@pytest.fixture
def videos(tmp_path):
    rng = np.random.default_rng(3)
    base = rng.integers(0, 256, (12, 120, 160, 3), np.uint8)
    base = np.stack([cv2.GaussianBlur(f, (3, 3), 0) for f in base])  # texture codecs keep
    soft, other = base.copy(), base.copy()
    box = (slice(30, 90), slice(40, 120))
    for f, s, o in zip(base, soft, other, strict=True):
        s[box] = cv2.GaussianBlur(f[box], (0, 0), 3)
        o[box] = np.roll(f[box], 7, axis=1)  # drawn anew, as sharp as the source
    paths = {}
    for name, frames in {"source": base, "soft": soft, "sharp": other}.items():
        paths[name] = tmp_path / f"{name}.mp4"
        write_mp4(paths[name], frames, fps=25, crf=4)
    return paths


def test_a_blurred_mouth_keeps_less_detail_than_a_sharp_one(videos, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["--source", str(videos["source"]), "--dub", f"soft={videos['soft']}",
                 "--dub", f"sharp={videos['sharp']}", "--out", str(out)])  # fmt: skip
    assert code == 0
    rows = (out / "dub_detail.tsv").read_text().splitlines()
    assert len(rows) == 13  # a header and the 12 frames
    import pandas as pd

    table = pd.read_csv(out / "dub_detail.tsv", sep="\t")
    assert (table.width >= 75).all() and (table.height >= 55).all()
    assert table.soft_laplacian.max() < 0.3 < 0.7 < table.sharp_laplacian.min()
    assert table.soft_gradient.max() < table.sharp_gradient.min()
    assert "| soft |" in capsys.readouterr().out


def test_frames_the_dubs_leave_alone_have_no_box():
    frame = np.full((40, 40, 3), 128, np.uint8)
    assert changed_box(frame, [frame.copy()]) is None


def test_a_dub_without_a_name_is_a_usage_error(videos):
    with pytest.raises(SystemExit) as err:
        main(["--source", str(videos["source"]), "--dub", str(videos["soft"])])
    assert err.value.code == 2
