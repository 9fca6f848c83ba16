"""``miketalk build``: a model from one video (s1's clips joined at test time), then say and dub.

The video is the .test face s1's six committed GRID clips joined (18 s, the
``s1_joined`` fixture of conftest.py), its last 6 s held out (``s1_built``); the
model it makes must be one that ``say``, ``say --audio`` and ``dub`` take.
Bad input is one line, exit status 2, and nothing written.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from miketalk import cli, defaults
from miketalk.speech import FestivalBackend

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "grid_s1"

needs_festival = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival not installed"
)


def test_the_build_flows_are_the_workflows_defaults() -> None:
    schema = yaml.safe_load((ROOT / "workflow/schemas/config.schema.yaml").read_text())
    flow = schema["properties"]["flow"]["properties"]
    assert flow["methods"]["default"]["bergen"] == defaults.BUILD_FLOW_METHOD
    assert flow["strategy"]["default"] == defaults.BUILD_FLOW_STRATEGY
    assert flow["mixed_window"]["default"] == defaults.BUILD_MIXED_WINDOW


def _blas_threads() -> list[int]:
    from threadpoolctl import threadpool_info

    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_a_build_and_a_workflow_stage_run_with_one_blas_thread(tmp_path, monkeypatch) -> None:
    """As the command line runs: a build called from Python (the page's build, a test's
    fixture) and the workflow's stages hold numpy's BLAS to one thread whatever the caller
    set (OpenBLAS's threads spin: the trained face's fits took 7.6 s of CPU with two and
    0.9 s with one), and give the caller's setting back."""
    from types import SimpleNamespace

    from threadpoolctl import threadpool_limits

    import miketalk.corpus.one_video as one_video
    from miketalk.building.from_video import build_model_from_video
    from miketalk.errors import MiketalkError
    from miketalk.stage import run_stage

    seen: list[list[int]] = []

    def stop_at_the_checks(*args, **kwargs):
        seen.append(_blas_threads())
        raise MiketalkError("stopped here")

    monkeypatch.setattr(one_video, "check_video_inputs", stop_at_the_checks)
    video = tmp_path / "in.mp4"
    video.write_bytes(b"")
    with threadpool_limits(limits=2, user_api="blas"):
        with pytest.raises(MiketalkError, match="stopped here"):
            build_model_from_video(video, tmp_path / "model", transcript="a b", progress=False)
        run_stage(SimpleNamespace(log=[], rule="r"), lambda: seen.append(_blas_threads()))
        assert _blas_threads() and set(_blas_threads()) == {2}
    assert seen == [[1] * len(_blas_threads())] * 2


def test_the_frame_a_face_is_built_in() -> None:
    """``--frame``/``--crop-size`` and the workflow's ``frame``/``crop_size``, read alike."""
    from miketalk.building.frame import FrameSettings
    from miketalk.errors import MiketalkError
    from miketalk.track.crop import FaceCropSettings

    assert FrameSettings("full").crop is None
    assert FrameSettings("crop").crop == FaceCropSettings()
    half = FrameSettings("crop", 128).crop
    assert (half.size, half.eye_distance, half.eyes_y) == (128, 36.0, FaceCropSettings().eyes_y)
    assert FrameSettings("crop", None, "accurate").crop == FaceCropSettings(conversion="accurate")
    assert FaceCropSettings().conversion == "auto"
    for frame, size, conversion, message in [
        ("full", 128, None, "crop_size goes with frame crop"),
        ("crop", 8, None, "the crop's size must be a whole number >= 16"),
        ("face", None, None, "the frame must be one of ['crop', 'full']"),
        ("full", None, "fast", "crop_conversion goes with frame crop"),
        ("crop", None, "exact", "conversion must be one of ['accurate', 'auto', 'fast']"),
    ]:
        with pytest.raises(MiketalkError, match=re.escape(message)):
            FrameSettings(frame, size, conversion)


def test_a_crop_records_its_conversion_and_an_old_record_reads_as_accurate() -> None:
    from miketalk.track.crop import FaceCropSettings, crop_doc, crop_from_doc

    fast = FaceCropSettings()
    assert crop_from_doc(crop_doc(fast)) == fast
    old = {k: v for k, v in crop_doc(fast).items() if k != "conversion"}  # before the choice
    assert crop_from_doc(old).conversion == "accurate"


def test_a_crop_conversion_without_the_crop_frame_is_one_line(capsys, tmp_path: Path) -> None:
    video = ROOT / "data" / "grid_s1" / "video" / "bbaf2n.mpg"
    code, _, err = _run(
        capsys, "build", str(video), "--transcript", str(video), "-o", str(tmp_path / "m"),
        "--frame", "full", "--crop-conversion", "accurate",
    )  # fmt: skip
    assert code == 2 and "Traceback" not in err
    assert (
        err.strip()
        .splitlines()[-1]
        .endswith("--crop-conversion goes with --frame crop (the face crop's pixels)")
    )


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def joined(s1_joined):
    return s1_joined


@pytest.fixture(scope="module")
def built(s1_built: Path) -> Path:
    return s1_built


@pytest.mark.slow
def test_build_writes_a_model_of_the_training_part(built: Path) -> None:
    manifest = json.loads((built / "manifest.json").read_text())
    assert manifest["size"] == [288, 360]  # --frame full: the frames' own
    background = json.loads((built / "background" / "background.json").read_text())
    assert "crop" not in background
    segments = json.loads((built / "build" / "segments.json").read_text())
    splits = [u["split"] for u in segments["utterances"]]
    assert splits == ["train"] * 4 + ["test"] * 2
    # no sound lag measured (dlib's 68 points: research-only data, the evaluation's alone)
    assert "sound_lag" not in segments and segments.get("sound_lag_s", 0.0) == 0.0
    assert (built / "background").is_dir() and (built / "coarticulation.json").is_file()
    assert not list(built.parent.glob("miketalk-build-*"))  # the work folder is gone


@pytest.mark.slow
def test_the_build_chooses_a_recordings_lipsync_on_its_held_back_clips(
    built: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from miketalk.building.lipsync_choice import CANDIDATES, MIN_T, choose_recording_lipsync
    from miketalk.model.parts import LIPSYNC_CHOICE, default_lipsync_model

    doc = json.loads((built / LIPSYNC_CHOICE).read_text())
    assert doc["recording"] in CANDIDATES and set(doc["scores"]) == set(CANDIDATES)
    clips = json.loads((built / "trained" / "frames.json").read_text())["clip_ids"]
    assert doc["clips"] == len(clips) and f"paper {doc['scores']['paper']:.2f}" in doc["reason"]
    scores, chosen, t = doc["scores"], doc["recording"], doc["t"]
    best = max(scores, key=scores.get)
    assert chosen == (best if best != "paper" and t[best] >= MIN_T else "paper")
    assert default_lipsync_model(built, recorded=True) == chosen
    # both fits of the trained face were judged, the one kept is the model's
    fits = doc["trained_fits"]
    fitted = json.loads((built / "trained" / "trained.json").read_text())["fitting"]
    assert scores["trained"] == fits["centred" if fitted["centred"] else "measured"]
    assert fitted["centred"] == (fits["t"] >= MIN_T)
    # the same corpus and model judge the same (the corpus kept beside the model)
    again = choose_recording_lipsync(built.parent / "corpus", built)
    assert (again.recording, again.scores, again.t) == (chosen, scores, t)
    # the trained face's cross-validated predictions the build kept are those a refit makes
    from miketalk.draw.trained import build as trained_build

    kept = trained_build.read_held_out(built / "trained", "heard")
    assert kept is not None and kept.shape[1] == 16
    monkeypatch.setattr(trained_build, "read_held_out", lambda *args: None)  # a face before
    refit = choose_recording_lipsync(built.parent / "corpus", built)
    assert refit.scores == pytest.approx(doc["scores"], abs=1e-4)


@pytest.mark.slow
@needs_festival
def test_say_and_dub_take_the_built_model(
    built: Path, joined, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = _run(
        capsys,
        "say",
        "Bin blue at F two now.",
        "--model",
        str(built),
        "-o",
        str(tmp_path / "a.mp4"),
    )
    assert code == 0, err
    assert "(blur, learned lip-sync)" in out  # typed text: the model's own coarticulation
    code, _, err = _run(
        capsys, "say", "--audio", str(DATA / "video" / "bbas3a.mpg"), "--text",
        "bin blue at s three again", "--model", str(built), "--lipsync-model", "learned",
        "-o", str(tmp_path / "b.mp4"),
    )  # fmt: skip
    assert code == 0, err
    code, out, err = _run(
        capsys, "dub", str(DATA / "video" / "srau3s.mpg"), "--text", "Hello world.",
        "--model", str(built), "-o", str(tmp_path / "c.mp4"),
    )  # fmt: skip
    assert code == 0, err
    assert "learned lip-sync)" in out
    # a recording with no lip-sync model asked for takes the one the build chose on its
    # held-back clips (lipsync.json) and says so; the trained face hears the recording, and a
    # trajectory asked for alone implies the trained face
    import json

    chosen = json.loads((built / "lipsync.json").read_text())["recording"]
    for asked, said in (
        ((), {"trained": "trained lip-sync, heard trajectory"}.get(chosen, f"{chosen} lip-sync")),
        (("--lipsync-model", "trained"), "trained lip-sync, heard trajectory"),
        (("--trajectory", "window"), "trained lip-sync, window trajectory"),
    ):
        name = "d_" + ("_".join(asked[1:]) or "chosen")
        code, out, err = _run(
            capsys, "say", "--audio", str(DATA / "video" / "bbas3a.mpg"), "--text",
            "bin blue at s three again", "--model", str(built), "-o", str(tmp_path / f"{name}.mp4"),
            *asked,
        )  # fmt: skip
        assert code == 0, err
        assert f"(blur, {said})" in out, (asked, out)
    assert all((tmp_path / f"{n}.mp4").stat().st_size > 0 for n in ("a", "b", "c", "d_chosen"))


def _damaged_copy(built: Path, where: Path, damage: str) -> tuple[Path, Path]:
    """A copy of the built model with one of its parts damaged, and the damaged file."""
    import shutil

    model = where / "damaged"
    shutil.copytree(built, model)
    victim = {
        "patches cut short": "trained/patches.npy",
        "patches changed": "trained/patches.npy",
        "background changed": "background/0003.png",
        "coarticulation missing": "coarticulation.json",
    }[damage]
    victim = model / victim
    data = bytearray(victim.read_bytes())
    victim.unlink()
    if damage == "patches cut short":
        victim.write_bytes(bytes(data[: len(data) // 2]))
    elif damage == "patches changed":  # a byte in every block, the .npy header kept
        for i in range(200, len(data), 1 << 20):
            data[i] ^= 0xFF
        victim.write_bytes(bytes(data))
    elif damage == "background changed":
        data[-100] ^= 0xFF
        victim.write_bytes(bytes(data))
    return model, victim


@pytest.mark.slow
def test_the_built_model_lists_every_file_it_needs(built: Path) -> None:
    manifest = json.loads((built / "manifest.json").read_text())
    files = {
        p.relative_to(built).as_posix()
        for p in built.rglob("*")
        if p.is_file() and p.name != "manifest.json"
    }
    assert set(manifest["files"]) == files  # before: the images and flows only
    assert {"coarticulation.json", "trained/patches.npy", "background/0000.png"} <= files
    assert "build/segments.json" in files  # its record too: what --force may replace
    patches = manifest["files"]["trained/patches.npy"]
    assert patches["block"] == 1 << 20
    assert len(patches["blocks"]) == -(-patches["size"] // patches["block"])


@pytest.mark.slow
@needs_festival
@pytest.mark.parametrize(
    "damage", ["patches cut short", "background changed", "coarticulation missing"]
)
def test_a_damaged_part_of_a_built_model_is_one_line_when_it_opens(
    built: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], damage: str
) -> None:
    model, victim = _damaged_copy(built, tmp_path, damage)
    code, out, err = _run(
        capsys, "say", "Bin blue at F two now.", "--model", str(model), "-o",
        str(tmp_path / "a.mp4"),
    )  # fmt: skip
    assert code == 2 and "Traceback" not in err and not out, err
    line = err.strip()
    assert "\n" not in line and str(victim) in line, err
    why = "is missing" if "missing" in damage else "does not match its checksum"
    if damage == "patches cut short":
        why = "bytes, the manifest says"
    assert why in line, err
    assert not (tmp_path / "a.mp4").exists()


@pytest.mark.slow
@needs_festival
def test_changed_patches_are_refused_before_the_trained_face_draws(
    built: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model, victim = _damaged_copy(built, tmp_path, "patches changed")
    # the patches are hashed block by block when read (too large to hash at every open):
    # the paper's and the learned lip-sync do not read them
    code, _, err = _run(
        capsys, "say", "Bin blue at F two now.", "--model", str(model), "--lipsync-model",
        "learned", "-o", str(tmp_path / "a.mp4"),
    )  # fmt: skip
    assert code == 0, err
    code, out, err = _run(
        capsys, "say", "Bin blue at F two now.", "--model", str(model), "--lipsync-model",
        "trained", "-o", str(tmp_path / "b.mp4"),
    )  # fmt: skip
    assert code == 2 and "Traceback" not in err and not out, err
    line = err.strip()
    assert "\n" not in line and f"{victim} does not match its checksum" in line, err
    assert not (tmp_path / "b.mp4").exists()


@pytest.mark.slow
def test_an_existing_model_needs_force(
    built: Path, joined, capsys: pytest.CaptureFixture[str]
) -> None:
    before = (built / "manifest.json").read_bytes()
    code, _, err = _run(
        capsys, "build", str(joined.video), "--transcript", str(joined.transcript), "-o", str(built)
    )
    assert code == 2 and err.count("\n") == 1 and "--force" in err
    assert (built / "manifest.json").read_bytes() == before


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["nothere.mp4", "--transcript", "{transcript}"], "video not found"),
        (["{video}", "--transcript", "{french}"], "another language"),
        (["{video}", "--subtitles", "{transcript}"], "must be .srt or .vtt"),
        (["{video}", "--transcript", "{transcript}", "--heldout-seconds", "60"], "holds out all"),
        (["{video}", "--transcript", "{short}"], "too little speech for the viseme classes"),
        (["{video}", "--subtitles", "{empty}"], "has no words"),
        (["{text}", "--transcript", "{transcript}"], "is not a video ffmpeg can read"),
    ],
    ids=[
        "no-video",
        "french",
        "not-subtitles",
        "all-held-out",
        "too-little",
        "empty-subtitles",
        "not-a-video",
    ],
)
def test_bad_input_is_one_line_and_nothing_written(
    joined, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    french = tmp_path / "fr.txt"
    french.write_text("Le chat est sur la table et il ne dort pas. Nous avons une maison.")
    short, empty, text = tmp_path / "short.txt", tmp_path / "empty.srt", tmp_path / "text.mp4"
    short.write_text("Bin blue at F two now.")  # 9 of the 16 viseme classes
    empty.write_text("")
    text.write_text("not a video")
    names = {"video": joined.video, "transcript": joined.transcript, "french": french,
             "short": short, "empty": empty, "text": text}  # fmt: skip
    model = tmp_path / "out" / "model"
    code, _, err = _run(
        capsys, "build", *[a.format(**names) for a in args], "-o", str(model), "--quiet"
    )
    assert code == 2, err
    assert err.count("\n") == 1 and message in err, err
    assert not model.exists() and not list((tmp_path / "out").glob(".*"))
