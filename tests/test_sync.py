"""The sync measure reads what ``say`` made: its timeline JSON, its frames, its mp4.

Also the timeline's JSON round trip, the phones recorded before oversampling,
and the summary of sync tables.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import test_model  # the tiny model of noise textures that tests/test_model.py builds

from miketalk.errors import MiketalkError
from miketalk.speech import FestivalBackend, Phone, Utterance
from miketalk.speech.backend import SpeechBackend
from miketalk.talk import lipsync
from miketalk.talk.model import Model
from miketalk.visemes import default_table

TABLE = default_table()

needs_festival = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival not installed"
)


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return test_model.model_dir.__wrapped__(tmp_path_factory)


def timed(spec: Sequence[tuple[str, float]]) -> tuple[Phone, ...]:
    out, t = [], 0.0
    for name, d in spec:
        out.append(Phone(name, t, t + d))
        t += d
    return tuple(out)


class Scripted(SpeechBackend):
    """Speaks fixed phones (silence); re-synthesis follows the dictated durations."""

    name = "scripted"
    rate = 16000

    def __init__(self, phones: Sequence[Phone]) -> None:
        self.phones = tuple(phones)

    def is_available(self) -> bool:
        return True

    def version(self) -> str:
        return "scripted"

    def _utterance(self, text: str, phones: tuple[Phone, ...]) -> Utterance:
        n = round(phones[-1].end * self.rate)
        return Utterance(text, np.zeros(n, np.int16), self.rate, phones, ((text, len(phones)),))

    def synthesize(self, text: str) -> Utterance:
        return self._utterance(text, self.phones)

    def resynthesize(self, utterance: Utterance, durations: Sequence[float]) -> Utterance:
        names = [p.name for p in utterance.phones]
        return self._utterance(utterance.text, timed(list(zip(names, durations, strict=True))))


ONE = timed([("pau", 0.2), ("w", 0.05), ("ay", 0.1), ("d", 0.05), ("pau", 0.2)])


def test_timeline_round_trips_through_json_exactly() -> None:
    timeline = lipsync.plan(ONE, TABLE, fps=29.97, duration=ONE[-1].end)
    doc = json.loads(json.dumps(timeline.to_dict()))
    assert lipsync.Timeline.from_dict(doc) == timeline
    assert lipsync.Timeline.from_dict({**doc, "text": "ignored"}) == timeline
    del doc["keyframes"]
    with pytest.raises(MiketalkError, match="not a timeline"):
        lipsync.Timeline.from_dict(doc)


def test_speak_in_sync_reports_the_phones_predicted_before_oversampling() -> None:
    backend = Scripted(ONE)
    planned: list[tuple[Phone, ...]] = []
    with backend.start("wide") as speech:
        utterance, timeline = lipsync.speak_in_sync(
            speech, TABLE, fps=30.0, displacement=lambda a, b: 0.0 if a == b else 20.0,
            max_px_per_frame=2.5, sampling="paper", on_planned=planned.append,
        )  # fmt: skip
    assert planned == [ONE]
    assert utterance.duration > ONE[-1].end  # lengthened; the plan is what came before
    assert timeline.phones == utterance.phones


def test_say_records_planned_phones_and_read_said_rebuilds_the_timeline(
    model_dir: Path, tmp_path: Path
) -> None:
    from miketalk.talk.say import read_said, say

    model = Model(model_dir)
    out = tmp_path / "wide.mp4"
    utterance, timeline = say(
        "wide", out, model=model, backend=Scripted(ONE), max_px_per_frame=0.5, sampling="paper"
    )
    said = read_said(out.with_suffix(".json"))
    assert said.timeline == timeline and said.text == "wide"
    assert said.planned_phones == ONE and said.max_px_per_frame == 0.5
    assert said.sampling == "paper"
    assert said.planned_duration == round(ONE[-1].end * 16000) / 16000
    assert utterance.duration > said.planned_duration  # 0.5 px per frame lengthens phones
    plain = lipsync.plan(said.planned_phones, TABLE, fps=30.0, duration=said.planned_duration)
    assert lipsync.largest_step(plain, model.displacement) > 0.5
    assert lipsync.largest_step(said.timeline, model.displacement) <= 0.5


def test_say_progress_bar_counts_every_frame(
    model_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from miketalk.talk.say import say

    _, timeline = say(
        "wide", tmp_path / "w.mp4", model=Model(model_dir), backend=Scripted(ONE), progress=True
    )
    n = len(timeline.frames)
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert last.startswith("rendering: 100%") and f"{n}/{n}" in last


def test_read_said_errors(tmp_path: Path) -> None:
    from miketalk.talk.say import read_said

    with pytest.raises(MiketalkError, match="no timeline"):
        read_said(tmp_path / "none.json")
    old = tmp_path / "old.json"
    timeline = lipsync.plan(ONE, TABLE, fps=30.0, duration=0.6)
    old.write_text(json.dumps({**timeline.to_dict(), "text": "x"}))
    with pytest.raises(MiketalkError, match="no planned_phones, planned_duration: make"):
        read_said(old)
    old.write_text("{")
    with pytest.raises(MiketalkError, match="cannot read"):
        read_said(old)


@needs_festival
def test_the_frames_measured_are_the_frames_say_writes(
    model_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from miketalk.evaluation.sync import utterance_frames
    from miketalk.talk import say as say_module
    from miketalk.talk.say import read_said, say

    written: list[np.ndarray] = []
    real_write_mp4 = say_module.write_mp4

    def capture(path, frames, *args, **kwargs):
        def tee():
            for frame in frames:
                written.append(frame.copy())
                yield frame

        return real_write_mp4(path, tee(), *args, **kwargs)

    monkeypatch.setattr(say_module, "write_mp4", capture)
    out = tmp_path / "hello.mp4"
    say("Hello world.", out, model=Model(model_dir))
    assert out.exists() and len(written) > 10
    said = read_said(out.with_suffix(".json"))
    measured = utterance_frames(said.timeline, Model(model_dir))
    assert measured.shape == (len(written), *written[0].shape)
    assert np.array_equal(measured, np.stack(written))


@needs_festival
def test_sync_table_of_an_utterance_reads_its_json_and_probes_its_mp4(
    model_dir: Path, tmp_path: Path
) -> None:
    from miketalk.evaluation.sync import summarize_sync, sync_table
    from miketalk.media.video import probe_durations
    from miketalk.talk.say import read_said, say

    model = Model(model_dir)
    out = tmp_path / "hello.mp4"
    say("Hello world.", out, model=model)
    said = read_said(out.with_suffix(".json"))
    mouth = np.zeros(model.size, bool)
    mouth[28:40, 14:34] = True
    table = sync_table(name="hello", said=said, model=model, table=TABLE, mouth=mouth, video=out)
    assert set(table["sentence"]) == {"hello"} and set(table["fps"]) == {30.0}
    value = table.set_index(["quantity", "key"])["value"]
    n = len(said.timeline.frames)
    assert (table["quantity"] == "psnr_full").sum() == n
    assert value[("video_seconds", "")] == n / 30.0
    assert value[("audio_seconds", "")] == said.timeline.duration
    assert value[("lengthened_seconds", "")] == said.timeline.duration - said.planned_duration
    assert value[("largest_step_px", "oversampled")] <= 2.5
    assert (value[("mp4_video_seconds", "")], value[("mp4_audio_seconds", "")]) == probe_durations(
        out
    )
    assert list(table["quantity"])[-2:] == ["mp4_video_seconds", "mp4_audio_seconds"]
    summary = summarize_sync(table).iloc[0]
    assert summary["frames"] == n and summary["largest_step_px_oversampled"] <= 2.5


def test_psnr_of_mean_mse_averages_the_error_not_the_decibels() -> None:
    from miketalk.evaluation.sync import psnr_of_mean_mse

    assert psnr_of_mean_mse([20.0, 20.0]) == pytest.approx(20.0)
    mse = 255.0**2 / np.array([10.0, 100.0])  # 10 dB and 20 dB
    assert psnr_of_mean_mse([10.0, 20.0]) == pytest.approx(10 * math.log10(255.0**2 / mse.mean()))
    assert psnr_of_mean_mse([math.inf, 20.0]) == pytest.approx(20.0 + 10 * math.log10(2))
    assert psnr_of_mean_mse([math.inf, math.inf]) == math.inf


def _tidy(sentence: str, fps: float, max_px: float | None, psnr: list[float]) -> pd.DataFrame:
    rows = [("psnr_mouth", k, p - 3) for k, p in enumerate(psnr)]
    rows += [("psnr_full", k, p) for k, p in enumerate(psnr)]
    rows += [
        ("mouth_lag_frames", "", 0.0),
        ("mouth_opening_corr", "", 0.9),
        ("viseme_offset_frames", "p@0.100", -0.25),
        ("viseme_offset_frames", "aa@0.300", 0.75),
        ("largest_step_px", "plain", 6.0),
        ("largest_step_px", "oversampled", 2.4),
        ("audio_seconds", "", 0.5),
        ("video_seconds", "", 0.5),
        ("duration_diff_frames", "", 0.0),
        ("lengthened_seconds", "", 0.1),
        ("mp4_video_seconds", "", 0.5),
        ("mp4_audio_seconds", "", 0.5),
    ]
    keys = {"sentence": sentence, "fps": fps, "max_px_per_frame": max_px}
    return pd.DataFrame([keys | {"quantity": q, "key": k, "value": float(v)} for q, k, v in rows])


def test_summarize_sync_one_row_per_utterance_and_setting() -> None:
    from miketalk.evaluation.sync import summarize_sync

    parts = [
        _tidy("quick", 30, 2.5, [20.0, 30.0, math.inf]),
        _tidy("hello", 30, 2.5, [25.0, 25.0]),
        _tidy("hello", 60, 2.5, [25.0]),
    ]
    # as the workflow does: each table through its CSV, then concatenated
    table = pd.concat(
        [
            pd.read_csv(
                io.StringIO(p.to_csv(index=False, float_format="%.6g")), keep_default_na=False
            )
            for p in parts
        ]
    )
    summary = summarize_sync(table)
    assert list(zip(summary["sentence"], summary["fps"], strict=True)) == [
        ("hello", 30), ("hello", 60), ("quick", 30),
    ]  # fmt: skip
    hello, _, quick = (summary.iloc[i] for i in range(3))
    assert list(summary["frames"]) == [2, 1, 3]
    assert hello["psnr_full"] == pytest.approx(25.0)
    assert hello["psnr_mouth"] == pytest.approx(22.0)
    assert quick["identical_frames"] == 1 and hello["identical_frames"] == 0
    assert quick["max_abs_viseme_offset_frames"] == 0.75
    assert quick["visemes_within_half_frame"] == 0.5
    assert quick["largest_step_px_plain"] == 6.0 and quick["largest_step_px_oversampled"] == 2.4
    assert quick["lengthened_seconds"] == pytest.approx(0.1)
    assert list(summary.columns) == [
        "sentence", "fps", "max_px_per_frame", "frames", "psnr_mouth", "psnr_full",
        "identical_frames", "mouth_lag_frames", "mouth_opening_corr",
        "max_abs_viseme_offset_frames", "visemes_within_half_frame", "largest_step_px_plain",
        "largest_step_px_oversampled", "audio_seconds", "video_seconds", "duration_diff_frames",
        "lengthened_seconds",
    ]  # fmt: skip


def test_sync_sweep_figure_is_drawn_by_name(tmp_path: Path) -> None:
    from miketalk.evaluation.sync import summarize_sync
    from miketalk.figures.plots import draw

    table = pd.concat([_tidy("quick", 30, px, [20.0, 25.0]) for px in (1.5, 2.5, 4.0)])
    summary = tmp_path / "summary.csv"
    summarize_sync(table).to_csv(summary, index=False)
    out = tmp_path / "sync.png"
    draw("sync_vs_max_px", out, summary_csv=summary)
    assert out.read_bytes().startswith(b"\x89PNG")
    with pytest.raises(MiketalkError, match="no figure 'nope'; known: epe_vs_levels"):
        draw("nope", out)
