"""The public API's settings (:mod:`miketalk.api.settings`): each rule checked in one place,
with one message naming the settings, which each front end names its own way."""

from __future__ import annotations

from pathlib import Path

import pytest

from miketalk import cli
from miketalk.api import (
    BuildSettings,
    CuesSettings,
    DubSettings,
    Recorded,
    SaySettings,
    SettingError,
    check,
)
from miketalk.cli.main import flag
from miketalk.serve.forms import FIELDS


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: SaySettings(sampling="none", max_px_per_frame=3),
         "max_px_per_frame has no effect with sampling none"),
        (lambda: DubSettings(sampling="none", max_px_per_frame=3),
         "max_px_per_frame has no effect with sampling none"),
        (lambda: SaySettings(max_slowdown=2),
         "max_slowdown caps how much sampling paper lengthens the speech; sampling blur keeps"),
        (lambda: SaySettings(trajectory="window", lipsync_model="learned"),
         "trajectory goes with lipsync_model trained"),
        (lambda: DubSettings(sampling="paper"), "sampling paper lengthens the speech"),
        (lambda: SaySettings(max_px_per_frame=0.1), "max_px_per_frame must be a number from 0.5"),
        (lambda: SaySettings(fps=0), "fps must be a number from 1 to 240"),
        (lambda: SaySettings(voice="bob"), "voice must be one of kal, ked, slt"),
        (lambda: BuildSettings(frame="full", crop_size=128),
         "crop_size goes with frame crop (the face crop's size)"),
        (lambda: BuildSettings(frame="full", crop_conversion="fast"),
         "crop_conversion goes with frame crop"),
        (lambda: CuesSettings(voice="bob"), "voice must be one of"),
    ],
)  # fmt: skip
def test_each_rule_is_one_setting_error_naming_the_settings(make, message: str) -> None:
    with pytest.raises(SettingError) as err:
        make()
    assert str(err.value).startswith(message)
    assert "--" not in str(err.value)  # the library names no flag


def test_a_setting_error_is_named_by_each_front_end() -> None:
    err = SettingError("{max_px_per_frame} has no effect with {sampling} none")
    assert err.settings == ("max_px_per_frame", "sampling")
    assert err.render(flag) == "--max-px-per-frame has no effect with --sampling none"
    assert SettingError("{lipsync_model} x {overwrite}").render(flag) == "--lipsync-model x --force"
    assert SettingError("{lipsync_model} and {audio}").render(FIELDS) == "lipsync and recording"


def test_the_defaults_are_the_engine_s() -> None:
    say = SaySettings()
    assert (say.fps, say.sampling, say.step_limit, say.lipsync_model) == (None, "blur", 2.5, None)
    assert SaySettings(sampling="none").step_limit is None
    assert DubSettings(max_px_per_frame=4).lipsync(25.0, None).max_px_per_frame == 4.0
    assert BuildSettings().frame_settings.crop is not None  # the face crop, 256 px


def test_settings_for_typed_text_are_refused_with_a_recording(tmp_path: Path) -> None:
    with pytest.raises(SettingError, match=r"^voice picks Festival's voice; with audio"):
        check(SaySettings(voice="ked", model=tmp_path), recorded=True)
    with pytest.raises(SettingError, match=r"^audio keeps the recording's own timing"):
        check(SaySettings(sampling="paper", model=tmp_path), recorded=True)
    with pytest.raises(SettingError, match=r"^the slt voice sets its own phone durations"):
        check(SaySettings(sampling="paper", voice="slt", model=tmp_path), recorded=False)
    with pytest.raises(SettingError, match=rf"^no model at {tmp_path}"):
        check(SaySettings(model=tmp_path), recorded=False)
    assert Recorded("a.wav").text is None


@pytest.mark.parametrize("command", ["say", "dub"])
def test_say_and_dub_refuse_a_step_limit_without_sampling_alike(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``dub`` once dropped ``--max-px-per-frame`` with ``--sampling none`` silently."""
    video = [str(tmp_path / "v.mkv")] if command == "dub" else []
    args = [command, *video, "--text", "Hi.", "-o", str(tmp_path / "o.mp4"),
            "--sampling", "none", "--max-px-per-frame", "3"]  # fmt: skip
    assert cli.main(args) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line == "miketalk: error: --max-px-per-frame has no effect with --sampling none"
    assert list(tmp_path.iterdir()) == []
