"""The trained face draws a join's flows once per pair of frames, and a repeated row once
(issue 50: ``say --audio`` of 12 minutes; DIS was 30 % of the main process's CPU), with the
frames it drew before: a fresh compositor for every row draws the same bytes."""

from __future__ import annotations

import numpy as np
from test_trained import _frames

from miketalk.draw.trained.mouths import MouthFrames
from miketalk.draw.trained.selection import PatchCompositor
from miketalk.flow import opencv


def test_flows_are_computed_once_a_pair_and_a_repeated_row_drawn_once(monkeypatch):
    rng = np.random.default_rng(4)
    patches = rng.integers(60, 250, (4, 40, 40, 3)).astype(np.uint8)
    frames = _frames(np.zeros((4, 1)), np.array([0, 0, 1, 1]))
    frames = MouthFrames(**{**frames.__dict__, "patches": patches,
                            "border": np.full((4, 3), 150.0), "patch": (0, 0, 40, 40)})  # fmt: skip
    face = np.full((40, 40, 3), 150, np.uint8)
    rows = [
        ((0, 0.8), (1, 0.2)), ((0, 0.8), (1, 0.2)),  # the same row twice
        ((0, 0.5), (1, 0.5)),  # the same pair at another weight
        ((2, 1.0),), ((1, 0.6), (3, 0.3), (0, 0.1)), ((0, 0.3), (1, 0.7)),
    ]  # fmt: skip
    fresh = [PatchCompositor(frames, face, joins="morph").frame(row) for row in rows]
    calls, real = [], opencv.dis_flow
    monkeypatch.setattr(opencv, "dis_flow", lambda a, b, **k: calls.append(1) or real(a, b, **k))
    compositor = PatchCompositor(frames, face, joins="morph")
    drawn = [compositor.frame(row) for row in rows]
    assert all(np.array_equal(a, b) for a, b in zip(fresh, drawn, strict=True))
    # (0, 1) once (three rows), (1, 3) once, then the 3-frame row's second step: 2 flows each
    assert len(calls) == 2 * 3
    drawn[0][:] = 0  # a frame handed out is the caller's: the next repeat is unchanged
    assert np.array_equal(compositor.frame(rows[5]), fresh[5])
