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
from miketalk.lipsync import sampling as talk_sampling
from miketalk.lipsync import timeline as lipsync
from miketalk.lipsync.settings import LipsyncSettings
from miketalk.model.face import Model
from miketalk.speech import FestivalBackend, Phone, Utterance
from miketalk.speech.backend import SpeechBackend
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
        utterance, timeline = talk_sampling.speak_in_sync(
            speech, TABLE, fps=30.0, displacement=lambda a, b: 0.0 if a == b else 20.0,
            max_px_per_frame=2.5, sampling="paper", on_planned=planned.append,
        )  # fmt: skip
    assert planned == [ONE]
    assert utterance.duration > ONE[-1].end  # lengthened; the plan is what came before
    assert timeline.phones == utterance.phones


def test_say_records_planned_phones_and_read_said_rebuilds_the_timeline(
    model_dir: Path, tmp_path: Path
) -> None:
    from miketalk.talk.say import say
    from miketalk.talk.utterance import read_said

    model = Model(model_dir)
    out = tmp_path / "wide.mp4"
    settings = LipsyncSettings(max_px_per_frame=0.5, sampling="paper")
    spoken = say("wide", out, model=model, backend=Scripted(ONE), settings=settings)
    utterance, timeline = spoken.utterance, spoken.timeline
    said = read_said(out.with_suffix(".json"))
    assert said.timeline == timeline and said.text == "wide"
    assert said.planned_phones == ONE and said.max_px_per_frame == 0.5
    assert said.sampling == "paper"
    assert said.planned_duration == round(ONE[-1].end * 16000) / 16000
    assert utterance.duration > said.planned_duration  # 0.5 px per frame lengthens phones
    plain = lipsync.plan(said.planned_phones, TABLE, fps=30.0, duration=said.planned_duration)
    assert talk_sampling.largest_step(plain, model.displacement) > 0.5
    assert talk_sampling.largest_step(said.timeline, model.displacement) <= 0.5


def test_say_progress_bar_counts_every_frame(
    model_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from miketalk.talk.say import say

    timeline = say(
        "wide", tmp_path / "w.mp4", model=Model(model_dir), backend=Scripted(ONE), progress=True
    ).timeline
    n = len(timeline.frames)
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert last.startswith("rendering: 100%") and f"{n}/{n}" in last


def test_read_said_errors(tmp_path: Path) -> None:
    from miketalk.talk.utterance import read_said

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
    from miketalk.talk import publish as publish_module
    from miketalk.talk.say import say
    from miketalk.talk.utterance import read_said
    from miketalk_lab.evaluation.sync import utterance_frames

    written: list[np.ndarray] = []

    class Capture(publish_module.StreamEncoder):  # the encoder the mp4 writer feeds
        def add(self, frame, audio=None):
            written.append(frame.copy())
            super().add(frame, audio)

    monkeypatch.setattr(publish_module, "StreamEncoder", Capture)
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
    from miketalk.media.video import probe_durations
    from miketalk.talk.say import say
    from miketalk.talk.utterance import read_said
    from miketalk_lab.evaluation.sync import MOTION_QUANTITIES, summarize_sync, sync_table

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
    assert set(table["sampling"]) == {"blur"}  # say's default, as its JSON records it
    # the motion measured again on the frames is what say recorded in the JSON
    recorded = json.loads(out.with_suffix(".json").read_text())["motion"]
    for quantity in MOTION_QUANTITIES:
        assert value[(quantity, "")] == pytest.approx(recorded[quantity], rel=1e-12), quantity
    summary = summarize_sync(table).iloc[0]
    assert summary["frames"] == n and summary["largest_step_px_oversampled"] <= 2.5
    assert summary["sampling"] == "blur" and summary["morphs"] == recorded["morphs"]


def test_psnr_of_mean_mse_averages_the_error_not_the_decibels() -> None:
    from miketalk_lab.evaluation.sync import psnr_of_mean_mse

    assert psnr_of_mean_mse([20.0, 20.0]) == pytest.approx(20.0)
    mse = 255.0**2 / np.array([10.0, 100.0])  # 10 dB and 20 dB
    assert psnr_of_mean_mse([10.0, 20.0]) == pytest.approx(10 * math.log10(255.0**2 / mse.mean()))
    assert psnr_of_mean_mse([math.inf, 20.0]) == pytest.approx(20.0 + 10 * math.log10(2))
    assert psnr_of_mean_mse([math.inf, math.inf]) == math.inf


def _tidy(
    sentence: str,
    fps: float,
    max_px: float | None,
    psnr: list[float],
    *,
    sampling: str = "blur",
    ratio: float = 1.0,
) -> pd.DataFrame:
    rows = [("psnr_mouth", k, p - 3) for k, p in enumerate(psnr)]
    rows += [("psnr_full", k, p) for k, p in enumerate(psnr)]
    rows += [
        ("mouth_lag_frames", "", 0.0),
        ("mouth_opening_corr", "", 0.9),
        ("viseme_offset_frames", "p@0.100", -0.25),
        ("viseme_offset_frames", "aa@0.300", 0.75),
        ("largest_step_px", "plain", 6.0),
        ("largest_step_px", "oversampled", 2.4),
        ("audio_seconds", "", 0.5 * ratio),
        ("video_seconds", "", 0.5 * ratio),
        ("duration_diff_frames", "", 0.0),
        ("lengthened_seconds", "", 0.5 * (ratio - 1)),
        ("duration_ratio", "", ratio),
        ("morphs", "", 3 * len(psnr) if sampling == "blur" else len(psnr)),
        ("largest_frame_motion_px", "", 6.0 if sampling == "blur" else 2.4),
        ("mean_jerk", "", 2.0 / ratio),
        ("largest_jerk", "", 5.0 / ratio),
        ("mp4_video_seconds", "", 0.5 * ratio),
        ("mp4_audio_seconds", "", 0.5 * ratio),
    ]
    keys = {"sentence": sentence, "sampling": sampling, "fps": fps, "max_px_per_frame": max_px}
    return pd.DataFrame([keys | {"quantity": q, "key": k, "value": float(v)} for q, k, v in rows])


def _through_csv(parts: list[pd.DataFrame]) -> pd.DataFrame:
    """As the workflow does: each table through its CSV, then concatenated."""
    return pd.concat(
        [
            pd.read_csv(
                io.StringIO(p.to_csv(index=False, float_format="%.6g")), keep_default_na=False
            )
            for p in parts
        ]
    )


def test_summarize_sync_one_row_per_utterance_and_setting() -> None:
    from miketalk_lab.evaluation.sync import summarize_sync

    parts = [
        _tidy("quick", 30, 2.5, [20.0, 30.0, math.inf]),
        _tidy("hello", 30, 2.5, [25.0, 25.0]),
        _tidy("hello", 60, 2.5, [25.0]),
    ]
    summary = summarize_sync(_through_csv(parts))
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
    assert quick["lengthened_seconds"] == 0.0
    assert quick["duration_ratio"] == 1.0 and quick["morphs"] == 9
    assert quick["largest_frame_motion_px"] == 6.0
    assert (quick["mean_jerk"], quick["largest_jerk"]) == (2.0, 5.0)
    assert list(summary.columns) == [
        "sentence", "sampling", "fps", "max_px_per_frame", "frames", "psnr_mouth", "psnr_full",
        "identical_frames", "mouth_lag_frames", "mouth_opening_corr",
        "max_abs_viseme_offset_frames", "visemes_within_half_frame", "largest_step_px_plain",
        "largest_step_px_oversampled", "audio_seconds", "video_seconds", "duration_diff_frames",
        "lengthened_seconds", "duration_ratio", "morphs", "largest_frame_motion_px", "mean_jerk",
        "largest_jerk",
    ]  # fmt: skip


def test_summarize_sync_groups_the_sampling_modes_apart() -> None:
    """The same sentence and setting in two modes: two rows, each with its own motion."""
    from miketalk_lab.evaluation.sync import summarize_sync

    parts = [
        _tidy("hello", 30, 2.5, [25.0] * 9, sampling="paper", ratio=3.0),
        _tidy("hello", 30, 2.5, [25.0] * 3, sampling="blur"),
        _tidy("hello", 30, 4.0, [25.0] * 6, sampling="paper", ratio=2.0),
    ]
    summary = summarize_sync(_through_csv(parts))
    assert list(zip(summary["sampling"], summary["max_px_per_frame"], strict=True)) == [
        ("blur", 2.5), ("paper", 2.5), ("paper", 4.0),
    ]  # fmt: skip
    blur, paper, _ = (summary.iloc[i] for i in range(3))
    assert (blur["frames"], paper["frames"]) == (3, 9)
    assert (blur["morphs"], paper["morphs"]) == (9, 9)
    assert (blur["duration_ratio"], paper["duration_ratio"]) == (1.0, 3.0)
    assert paper["lengthened_seconds"] == pytest.approx(1.0) and blur["lengthened_seconds"] == 0
    assert blur["mean_jerk"] == 2.0 and paper["mean_jerk"] == pytest.approx(2.0 / 3)


def _sweep_summary(tmp_path: Path) -> Path:
    """A sync sweep summary of both modes: three max_px at 30 fps, two more frame rates."""
    from miketalk_lab.evaluation.sync import summarize_sync

    parts = []
    for sampling, ratio in (("blur", 1.0), ("paper", 3.0)):
        for px, fps in ((1.5, 30), (2.5, 30), (4.0, 30), (2.5, 24), (2.5, 60)):
            ratio_here = 1.0 if sampling == "blur" else ratio * 2.5 / px
            parts.append(_tidy("quick", fps, px, [20.0, 25.0], sampling=sampling, ratio=ratio_here))
    summary = tmp_path / "summary.csv"
    summarize_sync(_through_csv(parts)).to_csv(summary, index=False)
    return summary


def _png_size(path: Path) -> tuple[int, int]:
    import cv2

    image = cv2.imread(str(path))
    assert image is not None, path
    return image.shape[1], image.shape[0]


def test_sync_sweep_figure_is_drawn_by_name_a_row_per_mode(tmp_path: Path) -> None:
    from miketalk_lab.figures.plots import draw

    summary = _sweep_summary(tmp_path)
    out = tmp_path / "sync.png"
    draw("sync_vs_max_px", out, summary_csv=summary)
    width, height = _png_size(out)
    one = tmp_path / "one.png"  # one mode: one row
    table = pd.read_csv(summary)
    table[table["sampling"] == "blur"].to_csv(tmp_path / "blur.csv", index=False)
    draw("sync_vs_max_px", one, summary_csv=tmp_path / "blur.csv")
    assert _png_size(one)[0] == width and 1.6 < height / _png_size(one)[1] < 2.4
    with pytest.raises(MiketalkError, match="no figure 'nope'; known: epe_vs_levels"):
        draw("nope", out)


def test_sampling_modes_figure_is_drawn_at_the_configured_rate(tmp_path: Path) -> None:
    from miketalk_lab.figures.plots import FIGURES, draw

    assert "sampling_vs_max_px" in FIGURES and "sampling_strip" in FIGURES
    summary = _sweep_summary(tmp_path)
    out = tmp_path / "modes.png"
    draw("sampling_vs_max_px", out, summary_csv=summary, fps=30)
    first = out.read_bytes()
    assert first.startswith(b"\x89PNG")
    draw("sampling_vs_max_px", out, summary_csv=summary, fps=30)
    assert out.read_bytes() == first  # deterministic
    with pytest.raises(MiketalkError, match="no rows at 25 fps"):
        draw("sampling_vs_max_px", out, summary_csv=summary, fps=25)


def test_sampling_strip_shows_both_modes_at_the_same_moments(
    model_dir: Path, tmp_path: Path
) -> None:
    """Rows are modes, columns the same moments of the speech; the paper row's frames
    run further apart in the lengthened video."""
    from miketalk.talk.say import say
    from miketalk_lab.figures.plots import draw

    model = Model(model_dir)
    timelines = []
    for sampling in ("blur", "paper"):
        out = tmp_path / f"{sampling}.mp4"
        say("wide", out, model=model, backend=Scripted(ONE),
            settings=LipsyncSettings(max_px_per_frame=1.0, sampling=sampling))  # fmt: skip
        timelines.append(out.with_suffix(".json"))
    strip = tmp_path / "strip.png"
    draw("sampling_strip", strip, model_dir=model_dir, timelines=timelines, morph={}, columns=4)
    width, height = _png_size(strip)
    assert width > height > 0
    first = strip.read_bytes()
    draw("sampling_strip", strip, model_dir=model_dir, timelines=timelines, morph={}, columns=4)
    assert strip.read_bytes() == first
    single = tmp_path / "single.png"
    draw("sampling_strip", single, model_dir=model_dir, timelines=timelines[:1], morph={},
         columns=4)  # fmt: skip
    assert _png_size(single)[0] == width and _png_size(single)[1] < height
    other = tmp_path / "other.mp4"
    say("wide", other, model=model, backend=Scripted(ONE[:3] + ONE[4:]),
        settings=LipsyncSettings(max_px_per_frame=1.0))  # fmt: skip
    with pytest.raises(MiketalkError, match="do not say the same phones"):
        draw("sampling_strip", strip, model_dir=model_dir,
             timelines=[timelines[0], other.with_suffix(".json")], morph={})  # fmt: skip


def test_sampling_bench_targets() -> None:
    """The bench's targets: blur within 10% of natural on every text, its step no larger."""
    from miketalk_lab.bench.sampling import TEXT_300, targets

    assert 290 <= len(TEXT_300.split()) <= 320
    rows = [("a", "blur", 1.0, 2.49), ("a", "paper", 3.0, 2.499), ("b", "blur", 1.05, 2.4995),
            ("b", "paper", 2.0, 2.499)]  # fmt: skip
    table = pd.DataFrame(rows, columns=["text", "sampling", "duration_ratio", "largest_step_px"])
    met = targets(table)
    assert met["blur_duration_within_10pct"] == 1.0 and met["blur_step_le_paper"] == 1.0
    assert met["blur_step_minus_paper_px"] == pytest.approx(0.0005)
    table.loc[2, ["duration_ratio", "largest_step_px"]] = (1.2, 2.6)
    assert targets(table) == pytest.approx(
        {"blur_duration_within_10pct": 0.0, "blur_step_le_paper": 0.0,
         "blur_step_minus_paper_px": 0.101}
    )  # fmt: skip
