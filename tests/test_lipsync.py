"""Lip-sync: transitions, Eq. 10 alphas, oversampling with re-synthesis."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.speech import FestivalBackend, Phone
from miketalk.talk import lipsync
from miketalk.visemes import default_table

TABLE = default_table()


def phones(spec: list[tuple[str, float]]) -> list[Phone]:
    out, t = [], 0.0
    for name, d in spec:
        out.append(Phone(name, t, t + d))
        t += d
    return out


ONE = phones([("pau", 0.2), ("w", 0.1), ("ah", 0.2), ("n", 0.1), ("pau", 0.2)])


def test_keyframes_at_phone_middles_and_diphthong_nuclei() -> None:
    keys = lipsync.keyframes(phones([("pau", 0.2), ("ow", 0.2), ("pau", 0.2)]), TABLE)
    assert [k.viseme for k in keys] == ["#", "o-ou", "u", "#"]
    assert [round(k.time, 6) for k in keys] == [0.1, 0.25, 0.35, 0.5]


def test_transition_stream_covers_the_audio() -> None:
    keys = lipsync.keyframes(ONE, TABLE)
    stream = lipsync.transitions(keys, 0.8)
    assert stream[0].start == 0.0 and stream[0].source == stream[0].target == "#"
    assert stream[-1].start + stream[-1].duration == pytest.approx(0.8)
    for a, b in pairwise(stream):
        assert a.start + a.duration == pytest.approx(b.start)
        assert a.target == b.source
    assert [(t.source, t.target) for t in stream[1:-1]] == [
        ("#", "w"), ("w", "uh"), ("uh", "k"), ("k", "#")
    ]  # fmt: skip


def test_alpha_follows_eq_10() -> None:
    timeline = lipsync.plan(ONE, TABLE, 30.0, 0.8)
    assert len(timeline.frames) == 24
    for f in timeline.frames:
        t = timeline.transitions[f.transition]
        assert t.start <= f.time < t.start + t.duration + 1e-9
        assert f.alpha == pytest.approx((f.time - t.start) / t.duration)


def test_each_viseme_is_shown_within_half_a_frame_of_its_phone_middle() -> None:
    timeline = lipsync.plan(ONE, TABLE, 30.0, 0.8)
    for key in timeline.keyframes:
        k = round(key.time * 30)
        assert abs(k / 30 - key.time) <= 0.5 / 30 + 1e-9


def test_oversampling_bounds_the_per_frame_motion() -> None:
    def disp(a: str, b: str) -> float:
        return 0.0 if a == b else 30.0

    before = lipsync.plan(ONE, TABLE, 30.0, 0.8)
    assert lipsync.largest_step(before, disp) > 2.5
    durations = lipsync.oversampled_durations(ONE, TABLE, 30.0, disp, 2.5)
    assert np.all(durations >= [p.duration for p in ONE])
    slow = phones(list(zip([p.name for p in ONE], durations, strict=True)))
    after = lipsync.plan(slow, TABLE, 30.0, slow[-1].end)
    assert lipsync.largest_step(after, disp) <= 2.5


def test_no_oversampling_needed_keeps_durations() -> None:
    durations = lipsync.oversampled_durations(ONE, TABLE, 30.0, lambda a, b: 1.0, 2.5)
    assert np.allclose(durations, [p.duration for p in ONE])


def test_bad_settings() -> None:
    with pytest.raises(MiketalkError):
        lipsync.plan(ONE, TABLE, 0.0, 0.8)
    with pytest.raises(MiketalkError):
        lipsync.oversampled_durations(ONE, TABLE, 30.0, lambda a, b: 1.0, 0.0)
    with pytest.raises(MiketalkError, match="unknown phone"):
        lipsync.plan(phones([("qq", 0.1)]), TABLE, 30.0, 0.1)


@pytest.mark.skipif(not FestivalBackend().is_available(), reason="Festival not installed")
def test_synchronize_resynthesizes_and_keeps_audio_and_video_together() -> None:
    festival = FestivalBackend()
    utt = festival.synthesize("One wide boat.")

    def disp(a: str, b: str) -> float:
        return 0.0 if a == b else 20.0

    out, timeline = lipsync.synchronize(
        utt, TABLE, fps=30.0, displacement=disp, max_px_per_frame=2.5, backend=festival
    )
    assert out.duration > utt.duration
    assert abs(len(timeline.frames) / 30.0 - out.duration) <= 1 / 30
    assert lipsync.largest_step(timeline, disp) <= 2.5
    assert [p.name for p in out.phones] == [p.name for p in utt.phones]


@pytest.mark.skipif(not FestivalBackend().is_available(), reason="Festival not installed")
def test_oversampled_text_in_many_chunks_stays_under_the_limit() -> None:
    # chunks are joined at whole audio samples and Festival rounds the times it is
    # given: the largest step must still not exceed the limit, not even by a hair
    festival = FestivalBackend(max_words=3)

    def disp(a: str, b: str) -> float:
        return 0.0 if a == b else 7.0 + 3.0 * (len(a) + 2 * len(b))

    text = "One wide boat sailed past the old mill and the quiet farm at dawn."
    with festival.start(text) as speech:
        out, timeline = lipsync.speak_in_sync(
            speech, TABLE, fps=30.0, displacement=disp, max_px_per_frame=2.5
        )
    assert len(out.chunks) > 3
    assert lipsync.largest_step(timeline, disp) <= 2.5
