"""``miketalk`` as a user meets it: every probe of issue 15, the behaviour asserted.

Each test runs the command line (a subprocess where the streams, exit status,
signals or the temporary directory matter; ``main()`` in-process where only
the exit status and the message do) on a model whose visemes are one texture
shifted by 0 to 45 pixels, with exact flows: transitions move far, so motion
blur and the paper's oversampling both have work to do.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures.process import BrokenProcessPool
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk import cli
from miketalk.flow import pair_path, write_flow_pair
from miketalk.media.audio import read_wav
from miketalk.media.images import write_png
from miketalk.media.video import probe_durations
from miketalk.model.write import build_model
from miketalk.visemes import VISEMES

#: How far each viseme's texture is shifted, pixels (0, 3, ..., 45).
SHIFT = {v: 3 * i for i, v in enumerate(VISEMES)}

LONG_TEXT = " ".join(
    [
        "MikeTalk morphs between visemes to make a face speak, one transition at a time.",
        "Each phone of the speech shows its viseme in full at its middle,",
        "and the flow between two visemes carries every pixel of one to its place in the",
        "other, so that the mouth opens and closes as the voice says the words.",
    ]
    * 3
)


def shifted_model(root: Path, size: int) -> Path:
    """A model of one smooth texture shifted by SHIFT[v] columns, with the exact flows."""
    rng = np.random.default_rng(7)
    noise = rng.random((size // 8, size // 8, 3))
    base = np.clip(cv2.resize(noise, (size, size), interpolation=cv2.INTER_CUBIC) * 255, 0, 255)
    base = base.astype(np.uint8)
    paths = {}
    for i, viseme in enumerate(VISEMES):
        paths[viseme] = root / "src" / f"{i}.png"
        paths[viseme].parent.mkdir(parents=True, exist_ok=True)
        write_png(paths[viseme], np.ascontiguousarray(np.roll(base, SHIFT[viseme], axis=1)))
    flows = root / "flows"
    flows.mkdir()
    for i, a in enumerate(VISEMES):
        for b in VISEMES[i + 1 :]:
            forward = np.zeros((size, size, 2), np.float32)
            forward[..., 0] = SHIFT[b] - SHIFT[a]
            write_flow_pair(
                pair_path(flows, a, b), forward, -forward, source=a, target=b,
                estimator="ground_truth", settings={},
            )  # fmt: skip
    return build_model(
        root / "model", images=paths, flows_dir=flows, estimator="ground_truth", settings={}
    )


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return shifted_model(tmp_path_factory.mktemp("model64"), 64)


@pytest.fixture(scope="module")
def big_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Larger images: a long text takes long enough to render to be interrupted."""
    return shifted_model(tmp_path_factory.mktemp("model160"), 160)


@pytest.fixture()
def dirs(tmp_path: Path) -> tuple[Path, Path]:
    """A working directory and a private TMPDIR, both empty."""
    work, scratch = tmp_path / "work", tmp_path / "tmp"
    work.mkdir()
    scratch.mkdir()
    return work, scratch


def _command(*args: str) -> list[str]:
    return [sys.executable, "-m", "miketalk.cli", *args]


def _env(scratch: Path) -> dict[str, str]:
    return {**os.environ, "TMPDIR": str(scratch)}


def run(
    *args: str | Path, cwd: Path, scratch: Path, timeout: float = 180
) -> subprocess.CompletedProcess:
    """``miketalk ARGS`` in ``cwd`` with TMPDIR ``scratch``."""
    return subprocess.run(
        _command(*map(str, args)), cwd=cwd, env=_env(scratch), capture_output=True, text=True,
        timeout=timeout, check=False,
    )  # fmt: skip


def assert_user_error(proc: subprocess.CompletedProcess, *fragments: str) -> str:
    """Exit 2, one line on stderr naming ``fragments``, nothing on stdout; the line."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("miketalk")
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert proc.stdout == ""
    return lines[0]


def snapshot(directory: Path) -> dict[str, bytes]:
    """Every file in ``directory`` (hidden ones included) and its bytes."""
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir()) if p.is_file()}


def good_pair(work: Path, scratch: Path, model: Path, name: str = "v.mp4") -> dict[str, bytes]:
    proc = run("say", "Hi.", "-o", name, "--model", model, cwd=work, scratch=scratch)
    assert proc.returncode == 0, proc.stderr
    return snapshot(work)


# ---------------------------------------------------------------------------
# natural speed
# ---------------------------------------------------------------------------


def test_say_keeps_the_speech_at_its_own_speed_with_small_steps(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    proc = run("say", "Hello world.", "-o", "h.mp4", "--model", model, "--json", cwd=work,
               scratch=scratch)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    motion = doc["motion"]
    assert doc["lipsync_model"] == "paper"  # the only one a synthetic face's model has
    assert doc["sampling"] == "blur" and abs(motion["duration_ratio"] - 1.0) <= 0.1
    assert motion["largest_step_px"] <= 2.5
    assert motion["largest_frame_motion_px"] > 2.5  # the speech moves fast: blur had work
    assert motion["morphs"] > motion["frames"]
    video, audio = probe_durations(work / "h.mp4")
    assert abs(video - motion["natural_duration"]) <= 1 / 30 and abs(audio - video) <= 1 / 30
    timeline = json.loads((work / "h.json").read_text())
    assert timeline["format"] == "miketalk-timeline/1"
    assert any("samples" in f for f in timeline["frames"])
    assert sorted(p.name for p in work.iterdir()) == ["h.json", "h.mp4"]
    assert list(scratch.iterdir()) == []


def test_paper_mode_lengthens_and_max_slowdown_caps_it(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    paper = run("say", "Hello world.", "-o", "p.mp4", "--model", model, "--json",
                "--sampling", "paper", cwd=work, scratch=scratch)  # fmt: skip
    assert paper.returncode == 0, paper.stderr
    motion = json.loads(paper.stdout)["motion"]
    assert motion["duration_ratio"] > 1.5
    assert motion["largest_step_px"] <= 2.5 and motion["morphs"] == motion["frames"]
    capped = run("say", "Hello world.", "-o", "c.mp4", "--model", model, "--json",
                 "--sampling", "paper", "--max-slowdown", "1.25", cwd=work,
                 scratch=scratch)  # fmt: skip
    assert capped.returncode == 0, capped.stderr
    motion = json.loads(capped.stdout)["motion"]
    assert 1.1 < motion["duration_ratio"] <= 1.25 + 0.01
    assert motion["largest_step_px"] <= 2.5  # what the cap left too fast is blurred
    assert motion["morphs"] > motion["frames"]


def test_learned_lipsync_draws_the_models_coarticulation(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    from miketalk.draw.coarticulation import CoarticulationParams
    from miketalk.model.write import write_coarticulation
    from miketalk.visemes import VisemeTable

    work, scratch = dirs
    learned_model = work.parent / "learned_model"
    shutil.copytree(model, learned_model)
    write_coarticulation(
        learned_model, CoarticulationParams.prior(VisemeTable().visemes, lead=0.02)
    )
    outputs = {}
    # l2 asks for no model: typed text takes the model's learned coarticulation
    for name, option in (("l1", "learned"), ("l2", None), ("p", "paper")):
        chosen = ("--lipsync-model", option) if option else ()
        proc = run("say", "Hello world.", "-o", f"{name}.mp4", "--model", learned_model, "--json",
                   *chosen, cwd=work, scratch=scratch)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        outputs[name] = json.loads(proc.stdout)
        option = option or "learned"
        assert outputs[name]["lipsync_model"] == option
        timeline = json.loads((work / f"{name}.json").read_text())
        assert timeline["lipsync_model"] == option
    learned = outputs["l1"]["motion"]
    # at the speech's own speed; the frames that move too fast are blurred (several states
    # averaged), so that consecutive states keep the step limit (issue 40)
    assert learned["frames"] == outputs["p"]["motion"]["frames"]
    assert learned["morphs"] > learned["frames"]
    assert learned["largest_step_px"] <= 2.5 + 1e-6 < learned["largest_frame_motion_px"]
    assert abs(learned["duration_ratio"] - 1.0) <= 0.1
    # the learned path undershoots: it moves less per frame than the paper's full transitions
    paper = outputs["p"]["motion"]
    assert 0 < learned["largest_frame_motion_px"] < paper["largest_frame_motion_px"]
    assert (work / "l1.mp4").read_bytes() == (work / "l2.mp4").read_bytes()
    assert (work / "l1.mp4").read_bytes() != (work / "p.mp4").read_bytes()
    assert list(scratch.iterdir()) == []


def test_learned_lipsync_needs_a_model_that_learned_it(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    for extra in ((), ("--audio", "missing.wav")):
        proc = run("say", "Hello world.", "-o", "v.mp4", "--model", model, "--lipsync-model",
                   "learned", *extra, cwd=work, scratch=scratch)  # fmt: skip
        assert_user_error(proc, "no learned coarticulation", "lipsync model 'paper'")
        proc = run("say", "Hello world.", "-o", "v.mp4", "--model", model, "--lipsync-model",
                   "trained", *extra, cwd=work, scratch=scratch)  # fmt: skip
        assert_user_error(proc, "no trained face", "lipsync model 'paper'")
    bad = run("say", "Hi.", "-o", "v.mp4", "--model", model, "--lipsync-model", "dominance",
              cwd=work, scratch=scratch)  # fmt: skip
    assert_user_error(bad, "--lipsync-model")
    # the heard trajectory listens to a recording; a trajectory is the trained face's only
    heard = run("say", "Hi.", "-o", "v.mp4", "--model", model, "--lipsync-model", "trained",
                "--trajectory", "heard", cwd=work, scratch=scratch)  # fmt: skip
    assert_user_error(heard, "--trajectory heard", "--audio")
    paper = run("say", "Hi.", "-o", "v.mp4", "--model", model, "--lipsync-model", "paper",
                "--trajectory", "window", cwd=work, scratch=scratch)  # fmt: skip
    assert_user_error(paper, "--trajectory goes with --lipsync-model trained")
    # a trajectory with no lip-sync model asks for the trained face, which this model lacks
    implied = run("say", "Hi.", "-o", "v.mp4", "--model", model, "--trajectory", "window",
                  cwd=work, scratch=scratch)  # fmt: skip
    assert_user_error(implied, "no trained face")
    assert list(work.iterdir()) == [] and list(scratch.iterdir()) == []


def test_say_output_is_byte_identical_run_to_run(model: Path, dirs: tuple[Path, Path]) -> None:
    work, scratch = dirs
    for name in ("a.mp4", "b.mp4"):
        proc = run("say", "Hello world.", "-o", name, "--model", model, cwd=work, scratch=scratch)
        assert proc.returncode == 0, proc.stderr
    assert (work / "a.mp4").read_bytes() == (work / "b.mp4").read_bytes()


def test_voices(model: Path, dirs: tuple[Path, Path]) -> None:
    work, scratch = dirs
    rates = {}
    for voice in ("kal", "ked", "slt"):
        proc = run("say", "Hello world.", "-o", f"{voice}.mp4", "--model", model, "--json",
                   "--voice", voice, cwd=work, scratch=scratch)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        doc = json.loads(proc.stdout)
        assert doc["voice"] == voice and doc["motion"]["duration_ratio"] == 1.0
        assert doc["motion"]["largest_step_px"] <= 2.5
        phones = run("phones", "Hello world.", "--json", "--voice", voice, cwd=work,
                     scratch=scratch)  # fmt: skip
        rates[voice] = json.loads(phones.stdout)["rate"]
    assert rates == {"kal": 16000, "ked": 16000, "slt": 32000}
    # the HTS voice sets its own durations: the paper's lengthening cannot apply
    hts = run("say", "Hi.", "-o", "x.mp4", "--model", model, "--voice", "slt", "--sampling",
              "paper", "-v", cwd=work, scratch=scratch)  # fmt: skip
    assert_user_error(hts, "slt voice sets its own phone durations")
    assert not (work / "x.mp4").exists()


# ---------------------------------------------------------------------------
# no file is lost
# ---------------------------------------------------------------------------


def test_a_directory_named_like_the_json_keeps_the_good_mp4(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    good = good_pair(work, scratch, model)
    (work / "v.json").unlink()
    (work / "v.json").mkdir()
    proc = run("say", "Hi.", "-o", "v.mp4", "--model", model, "-v", cwd=work, scratch=scratch)
    assert_user_error(proc, "v.json is a directory")
    assert (work / "v.mp4").read_bytes() == good["v.mp4"]
    assert sorted(p.name for p in work.iterdir()) == ["v.json", "v.mp4"]
    assert list(scratch.iterdir()) == []


def test_output_that_is_a_directory_is_refused_before_any_work(
    model: Path, dirs: tuple[Path, Path], work_started: Path
) -> None:
    work, scratch = dirs
    (work / "out.mp4").mkdir()
    proc = run("say", "Hi.", "-o", "out.mp4", "--model", model, "-v", cwd=work, scratch=scratch)
    assert_user_error(proc, "out.mp4 is a directory")
    assert not work_started.exists()  # neither Festival nor ffmpeg ran
    assert list((work / "out.mp4").iterdir()) == []
    not_mp4 = run("say", "Hi.", "-o", ".", "--model", model, cwd=work, scratch=scratch)
    assert_user_error(not_mp4, "must be an .mp4 file")


@pytest.fixture()
def read_only(tmp_path: Path) -> Iterator[Path]:
    """A directory no file can be created in, also for root (immutable, or under /sys)."""
    directory = tmp_path / "locked"
    directory.mkdir()
    if os.geteuid() != 0:
        directory.chmod(0o555)
        yield directory
        directory.chmod(0o755)
        return
    locked = subprocess.run(["chattr", "+i", str(directory)], capture_output=True, check=False)
    if locked.returncode == 0:
        yield directory
        subprocess.run(["chattr", "-i", str(directory)], check=True)
    else:  # a file system without attributes (tmpfs): /sys refuses new files, also to root
        yield Path("/sys")


def test_a_read_only_directory_is_one_line_before_any_work(
    model: Path, dirs: tuple[Path, Path], read_only: Path
) -> None:
    work, scratch = dirs
    with pytest.raises(OSError):
        (read_only / "probe").write_bytes(b"")
    proc = run("say", "Hi.", "-o", read_only / "v.mp4", "--model", model, "-v", cwd=work,
               scratch=scratch)  # fmt: skip
    line = assert_user_error(proc, "cannot write", "v.mp4")
    assert "Festival" not in line
    assert list(scratch.iterdir()) == []


def test_an_unrelated_json_is_not_overwritten_without_force(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    (work / "notes.json").write_text('{"mine": true}')
    proc = run("say", "Hi.", "-o", "notes.mp4", "--model", model, cwd=work, scratch=scratch)
    assert_user_error(proc, "notes.json exists and is not a miketalk timeline", "--force")
    assert (work / "notes.json").read_text() == '{"mine": true}'
    assert not (work / "notes.mp4").exists()
    forced = run("say", "Hi.", "-o", "notes.mp4", "--model", model, "--force", cwd=work,
                 scratch=scratch)  # fmt: skip
    assert forced.returncode == 0, forced.stderr
    assert json.loads((work / "notes.json").read_text())["format"] == "miketalk-timeline/1"
    again = run("say", "Hello.", "-o", "notes.mp4", "--model", model, cwd=work, scratch=scratch)
    assert again.returncode == 0, again.stderr  # its own timeline is replaced without --force


def _wait_for(pattern: str, where: Path, proc: subprocess.Popen, limit: float = 90) -> None:
    deadline = time.monotonic() + limit
    while not list(where.glob(pattern)):
        assert proc.poll() is None, proc.communicate()
        if time.monotonic() > deadline:  # a poll's generous deadline, not a timed assertion
            pytest.fail(f"no {pattern} in {where} after {limit} s")
        time.sleep(0.005)


@pytest.mark.parametrize(
    ("signum", "status", "word", "stage"),
    [
        (signal.SIGTERM, 143, "terminated", "miketalk-mp4-*"),
        (signal.SIGINT, 130, "interrupted", "miketalk-mp4-*"),
        (signal.SIGTERM, 143, "terminated", "miketalk-festival-*"),
    ],
)
def test_a_signal_keeps_the_old_pair_and_leaves_nothing(
    big_model: Path, dirs: tuple[Path, Path], signum: int, status: int, word: str, stage: str
) -> None:
    work, scratch = dirs
    good = good_pair(work, scratch, big_model)
    proc = subprocess.Popen(
        _command("say", LONG_TEXT, "-o", "v.mp4", "--model", str(big_model)),
        cwd=work, env=_env(scratch), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        _wait_for(stage, scratch, proc)
        proc.send_signal(signum)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == status, err
    assert err.strip() == f"miketalk: {word}" and out == ""
    assert snapshot(work) == good
    assert list(scratch.iterdir()) == []


def test_scratch_of_a_killed_run_is_removed_by_the_next(
    big_model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    good = good_pair(work, scratch, big_model)
    proc = subprocess.Popen(
        _command("say", LONG_TEXT, "-o", "v.mp4", "--model", str(big_model)),
        cwd=work, env=_env(scratch), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        _wait_for("miketalk-mp4-*", scratch, proc)
    finally:
        proc.kill()
        proc.wait()
    time.sleep(1.0)  # its ffmpeg, orphaned, finishes reading its pipe and exits
    left = {p.name for p in scratch.iterdir()} | {p.name for p in work.glob(".v.*")}
    assert any(n.startswith("miketalk-mp4-") for n in left)
    assert any(n.startswith(".v.mp4.miketalk-") for n in left)
    assert {k: v for k, v in snapshot(work).items() if not k.startswith(".")} == good
    proc = run("say", "Hi.", "-o", "w.mp4", "--model", big_model, "-v", cwd=work, scratch=scratch)
    assert proc.returncode == 0, proc.stderr
    assert list(scratch.iterdir()) == []
    assert "left by a run that was killed" in proc.stderr
    assert sorted(p.name for p in work.iterdir()) == ["v.json", "v.mp4", "w.json", "w.mp4"]


# ---------------------------------------------------------------------------
# user mistakes: one line, exit 2, before the work
# ---------------------------------------------------------------------------


def _main_error(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    """``main(args)`` ends with status 2 and one line on stderr; the line."""
    try:
        status = cli.main(list(args))
    except SystemExit as exit_:
        status = exit_.code
    captured = capsys.readouterr()
    assert status == 2, captured.err
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert captured.out == ""
    return lines[0]


@pytest.mark.parametrize("fps", ["0", "nan", "inf", "-inf", "1e308", "1e-9", "0.001", "-30", "x"])
def test_fps_out_of_range(capsys: pytest.CaptureFixture[str], tmp_path: Path, fps: str) -> None:
    line = _main_error(capsys, "say", "Hi.", "-o", str(tmp_path / "v.mp4"), f"--fps={fps}")
    assert "--fps" in line
    assert ("from 1 to 240" in line) or ("not a number" in line and fps == "x")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("px", ["nan", "-1", "0", "1e-9", "0.01", "inf", "1e9"])
def test_max_px_per_frame_out_of_range(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, px: str
) -> None:
    line = _main_error(capsys, "say", "Hi.", "-o", str(tmp_path / "v.mp4"),
                       f"--max-px-per-frame={px}")  # fmt: skip
    assert "--max-px-per-frame" in line and "from 0.5 to 100" in line


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--no-oversampling", "--max-px-per-frame=-1"], "from 0.5 to 100"),
        (["--no-oversampling", "--max-px-per-frame=3"], "no effect with --sampling none"),
        (["--no-oversampling", "--sampling", "paper"], "--no-oversampling is --sampling none"),
        (["--max-slowdown", "2"], "--max-slowdown caps"),
        (["--sampling", "paper", "--max-slowdown", "0.5"], "at least 1"),
        (["--sampling", "paper", "--max-slowdown", "nan"], "at least 1"),
        (["--sampling", "paper", "--max-slowdown", "inf"], "finite"),
        (["--sampling", "fast"], "invalid choice"),
        (["--voice", "bob"], "invalid choice"),
        (["--timings", "x.align"], "--timings goes with --audio"),
        (["--phones", "recognized"], "--phones goes with --audio"),
        (["--phones", "guessed"], "invalid choice"),
        (
            ["--audio", "a.wav", "--timings", "x.align", "--phones", "recognized"],
            "--phones recognized takes the recording's words from the recognizer; --timings",
        ),
    ],
)
def test_contradictory_or_bad_options(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, options: list[str], message: str
) -> None:
    line = _main_error(capsys, "say", "Hi.", "-o", str(tmp_path / "v.mp4"), *options)
    assert message in line
    assert list(tmp_path.iterdir()) == []


def _broken_model(model: Path, tmp_path: Path, change: Callable[[dict], str]) -> Path:
    broken = tmp_path / "broken"
    shutil.copytree(model, broken)
    manifest = json.loads((broken / "manifest.json").read_text())
    (broken / "manifest.json").write_text(change(manifest))
    return broken


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda m: "[]", "is not a miketalk-model/1 manifest: at the top level"),
        (lambda m: json.dumps(m | {"format": "x/1"}), "(its format is 'x/1')"),
        (lambda m: json.dumps({k: v for k, v in m.items() if k != "visemes"}),
         "'visemes' is a required property"),
        (lambda m: json.dumps(m | {"visemes": "p"}), "at visemes, 'p' is not of type 'array'"),
        (lambda m: json.dumps(m | {"size": [64]}), "at size"),
        (lambda m: json.dumps(m).replace(": 3.0", ": NaN", 1), "NaN is not a JSON number"),
        (lambda m: json.dumps(m | {"images": m["images"] | {"p": "../../etc/passwd"}}),
         "'../../etc/passwd', is outside the model directory"),
        (lambda m: json.dumps(m | {"images": m["images"] | {"p": "/etc/passwd"}}),
         "is outside the model directory"),
        (lambda m: json.dumps(m | {"images": {}}), "no image for viseme"),
        (lambda m: json.dumps(m | {"max_displacement": {}}), "max_displacement lacks 240"),
        (lambda m: "{", "cannot read model manifest"),
    ],
)  # fmt: skip
def test_a_bad_manifest_is_one_line(
    model: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: Callable[[dict], str],
    message: str,
) -> None:
    broken = _broken_model(model, tmp_path, change)
    line = _main_error(capsys, "say", "Hi.", "-o", str(tmp_path / "v.mp4"), "--model", str(broken))
    assert message in line
    assert not (tmp_path / "v.mp4").exists()


def test_a_flow_file_of_another_size_is_named(
    model: Path, big_model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mixed = tmp_path / "mixed"
    shutil.copytree(model, mixed)
    victim = pair_path(mixed / "flows", "p", "f")
    victim.unlink()  # a hard link of the model's own file
    shutil.copyfile(pair_path(big_model / "flows", "p", "f"), victim)
    # the manifest records each file's size: found when the model opens (issue 40)
    line = _main_error(capsys, "say", "Bob feeds Pat.", "-o", str(tmp_path / "v.mp4"),
                       "--model", str(mixed))  # fmt: skip
    assert str(victim) in line and "the manifest says" in line
    # a model written before the sizes were recorded: found when the flow is read
    manifest = json.loads((mixed / "manifest.json").read_text())
    del manifest["files"]
    (mixed / "manifest.json").write_text(json.dumps(manifest))
    line = _main_error(capsys, "say", "Bob feeds Pat.", "-o", str(tmp_path / "v.mp4"),
                       "--model", str(mixed))  # fmt: skip
    assert str(victim) in line and "160x160" in line and "64x64" in line
    assert "flow01" not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mixed"]


@pytest.mark.parametrize("damage", ["changed", "missing", "image changed"])
def test_a_damaged_file_the_text_does_not_need_is_refused_when_the_model_opens(
    model: Path, dirs: tuple[Path, Path], damage: str
) -> None:
    work, scratch = dirs
    broken = work / "model"
    shutil.copytree(model, broken)
    # "Bob feeds Pat." draws neither k nor uu: before, a changed byte there was not found
    victim = pair_path(broken / "flows", "k", "uu")
    if damage == "image changed":
        victim = broken / json.loads((broken / "manifest.json").read_text())["images"]["uu"]
    data = bytearray(victim.read_bytes())
    victim.unlink()
    if damage != "missing":
        data[-20] ^= 0xFF  # the same size: for the flow, a whole OpenEXR file
        victim.write_bytes(bytes(data))
    proc = run("say", "Bob feeds Pat.", "-o", "v.mp4", "--model", broken,
               cwd=work, scratch=scratch)  # fmt: skip
    why = "is missing" if damage == "missing" else "does not match its checksum"
    assert_user_error(proc, str(victim), why)
    assert sorted(p.name for p in work.iterdir()) == ["model"]


def test_native_warnings_go_to_stderr_and_stdout_stays_clean(
    model: Path, dirs: tuple[Path, Path]
) -> None:
    work, scratch = dirs
    broken = work / "model"
    shutil.copytree(model, broken)
    # a model written before its manifest listed checksums, whose flow file is whole but
    # for a chunk's scanline number: OpenEXR's own complaints, then one line naming it
    manifest = json.loads((broken / "manifest.json").read_text())
    del manifest["files"]
    (broken / "manifest.json").write_text(json.dumps(manifest))
    victim = pair_path(broken / "flows", "p", "f")
    data = bytearray(victim.read_bytes())
    table = 8  # the chunk table follows the header's attributes (name, type, size, value)
    while data[table]:
        kind_end = data.index(b"\0", data.index(b"\0", table) + 1)
        table = kind_end + 5 + struct.unpack_from("<i", data, kind_end + 1)[0]
    (chunk,) = struct.unpack_from("<Q", data, table + 1 + 8 * 10)
    struct.pack_into("<i", data, chunk, 99999)
    victim.write_bytes(bytes(data))
    proc = run("say", "Bob feeds Pat.", "-o", "v.mp4", "--model", broken, "--json",
               cwd=work, scratch=scratch)  # fmt: skip
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert lines[-1].startswith("miketalk: error: flow file") and victim.name in lines[-1]
    relayed = [ln for ln in lines[:-1] if ln.startswith("miketalk: WARNING: ")]
    assert relayed and relayed == lines[:-1]  # OpenEXR's own lines, through logging
    assert any("Warning" in ln or "EXR" in ln for ln in relayed)
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("command", ["say", "phones"])
def test_a_very_long_word_is_refused_before_festival(
    model: Path, dirs: tuple[Path, Path], command: str, work_started: Path
) -> None:
    work, scratch = dirs
    word = "supercalifragilistic" * 500
    args = ["-o", "v.mp4", "--model", str(model)] if command == "say" else []
    proc = run(command, word, *args, cwd=work, scratch=scratch)
    assert_user_error(proc, "is 10000 letters long", "up to 100")
    assert not work_started.exists()  # Festival never started
    long_ok = run("phones", "supercalifragilistic" * 5, cwd=work, scratch=scratch)
    assert long_ok.returncode == 0, long_ok.stderr


def test_help_says_what_files_are_written(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        cli.main(["say", "--help"])
    assert done.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "Writes two files: OUTPUT (an .mp4" in text and "suffix .json" in text
    assert "--sampling" in text and "--max-slowdown" in text and "--force" in text
    with pytest.raises(SystemExit):
        cli.main(["cues", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Rhubarb" in text and ".TextGrid" in text


def test_verbose_shows_progress_and_timings(model: Path, dirs: tuple[Path, Path]) -> None:
    work, scratch = dirs
    proc = run("say", "Hello.", "-o", "v.mp4", "--model", model, "-v", cwd=work, scratch=scratch)
    assert proc.returncode == 0, proc.stderr
    info = [ln for ln in proc.stderr.splitlines() if ln.startswith("miketalk: INFO: ")]
    text = "\n".join(info)
    for step in ("Festival started", "opened", "speech:", "rendered", "say took"):
        assert step in text, proc.stderr
    quiet = run("say", "Hello.", "-o", "q.mp4", "--model", model, cwd=work, scratch=scratch)
    assert quiet.stderr == ""


def test_phones_json_is_clean_json_on_stdout(dirs: tuple[Path, Path]) -> None:
    work, scratch = dirs
    proc = run("phones", "Hello world", "--json", cwd=work, scratch=scratch)
    assert proc.returncode == 0 and proc.stderr == ""
    doc = json.loads(proc.stdout)
    assert [p["phone"] for p in doc["phones"]][:3] == ["pau", "hh", "ax"]
    assert math.isfinite(doc["duration"])


# ---------------------------------------------------------------------------
# cues: Rhubarb JSON/TSV and a Praat TextGrid
# ---------------------------------------------------------------------------


def test_cues_in_rhubarb_json_tsv_and_a_textgrid(dirs: tuple[Path, Path]) -> None:
    from praatio import textgrid

    work, scratch = dirs
    proc = run("cues", "Hello world", "-o", "h.json", "-o", "h.tsv", "-o", "h.TextGrid",
               "--wav", "h.wav", cwd=work, scratch=scratch)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == ""
    doc = json.loads((work / "h.json").read_text())
    assert set(doc) == {"metadata", "mouthCues"}
    assert doc["metadata"]["soundFile"] == str((work / "h.wav").resolve())
    cues = doc["mouthCues"]
    assert cues[0]["start"] == 0 and cues[-1]["end"] == doc["metadata"]["duration"]
    assert all(a["end"] == b["start"] and a["value"] != b["value"] for a, b in pairwise(cues))
    assert {c["value"] for c in cues} <= set("ABCDEFGHX")
    assert [c["value"] for c in cues][:3] == ["X", "B", "C"]  # silence, h, ax
    assert "H" in {c["value"] for c in cues}  # the l of hello
    tsv = (work / "h.tsv").read_text().splitlines()
    assert [ln.split("\t") for ln in tsv[:-1]] == [[f"{c['start']:.2f}", c["value"]] for c in cues]
    assert tsv[-1] == f"{doc['metadata']['duration']:.2f}\tX"
    grid = textgrid.openTextgrid(str(work / "h.TextGrid"), includeEmptyIntervals=True)
    assert grid.tierNames == ("phones", "visemes", "keyframes")
    phones = grid.getTier("phones").entries
    assert [e.label for e in phones] == "pau hh ax l ow w er l d pau".split()
    assert [e.label for e in grid.getTier("visemes").entries][4:6] == ["o-ou", "u"]  # ow
    assert len(grid.getTier("keyframes").entries) == 11
    samples, rate = read_wav(work / "h.wav")  # the sound the cues belong to
    assert abs(len(samples) / rate - phones[-1].end) < 1e-3
    stdout = run("cues", "Hello world", cwd=work, scratch=scratch)
    assert stdout.stdout == (work / "h.tsv").read_text()
    basic = run("cues", "Hello world", "--extended-shapes", "", "--format", "json", cwd=work,
                scratch=scratch)  # fmt: skip
    assert {c["value"] for c in json.loads(basic.stdout)["mouthCues"]} <= set("ABCDEF")


def test_cues_into_a_read_only_directory_is_one_line(
    dirs: tuple[Path, Path], read_only: Path
) -> None:
    work, scratch = dirs
    proc = run("cues", "Hello", "-o", read_only / "h.json", "-v", cwd=work, scratch=scratch)
    assert_user_error(proc, "cannot write", "h.json")
    wav = run("cues", "Hello", "--wav", read_only / "h.wav", cwd=work, scratch=scratch)
    assert_user_error(wav, "cannot write", "h.wav")


def test_cues_of_a_recording(dirs: tuple[Path, Path]) -> None:
    work, scratch = dirs
    made = run("cues", "Bob feeds Pat.", "--wav", "bob.wav", "-o", "tts.json", cwd=work,
               scratch=scratch)  # fmt: skip
    assert made.returncode == 0, made.stderr
    proc = run("cues", "--audio", "bob.wav", "--text", "Bob feeds Pat.", "-o", "rec.json",
               "-o", "rec.TextGrid", cwd=work, scratch=scratch)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    tts = json.loads((work / "tts.json").read_text())
    rec = json.loads((work / "rec.json").read_text())
    assert rec["metadata"]["soundFile"] == str((work / "bob.wav").resolve())
    assert abs(rec["metadata"]["duration"] - tts["metadata"]["duration"]) <= 0.01
    closed = [c for c in rec["mouthCues"] if c["value"] == "A"]  # the b's and p
    assert len(closed) >= 2


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["-o", "h.txt"], "cannot tell the format of 'h.txt'"),
        (["-o", "h.json", "-o", "h.json"], "named twice"),
        (["--wav", "h.mp3"], "--wav must name a .wav file"),
        (["--timings", "t.align"], "--timings goes with --audio"),
        (["--extended-shapes", "Q"], "extended shapes are letters of GHX"),
    ],
)
def test_cues_mistakes(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    args: list[str],
    message: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    line = _main_error(capsys, "cues", "Hello", *args)
    assert message in line
    assert list(tmp_path.iterdir()) == []


def test_a_termination_inside_a_finalizer_waits_for_it(tmp_path: Path) -> None:
    code = """
import os, signal, sys, time
from miketalk.console import Terminated, handle_termination

class Closes:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)  # the signal arrives while this finalizer runs
        print("finalizer done", flush=True)

with handle_termination():
    try:
        obj = Closes()
        del obj
        time.sleep(5)
        print("not stopped")
    except Terminated as err:
        print("terminated by", signal.Signals(err.signum).name)
"""
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=30, check=False
    )
    assert proc.stdout.split("\n")[:2] == ["finalizer done", "terminated by SIGTERM"]
    assert proc.stderr == ""


def test_a_signal_between_making_a_temporary_and_recording_it_leaves_nothing(
    tmp_path: Path,
) -> None:
    code = f"""
import os, signal
from pathlib import Path
from miketalk.console import Terminated, handle_termination
from miketalk.media import atomic

made = atomic._temporary

def made_then_signalled(final, suffix):
    tmp = made(final, suffix)
    os.kill(os.getpid(), signal.SIGTERM)  # lands before atomic_paths has recorded tmp
    return tmp

atomic._temporary = made_then_signalled
with handle_termination():
    try:
        with atomic.atomic_paths([Path({str(tmp_path)!r}) / "v.mp4"]) as (tmp,):
            print("wrote into", tmp.name)
    except Terminated:
        print("terminated")
"""
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=30, check=False
    )
    assert proc.stdout.strip() == "terminated" and proc.stderr == ""
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_handled_inside_a_deferred_block_is_held_until_it_ends(signum: int) -> None:
    # pthread_sigmask blocks a signal in the calling thread only: with other threads alive
    # the kernel hands it to one of them, and Python runs the handler in the main thread
    # at once, inside the block. The handler itself must hold it.
    from miketalk.console import handle_termination
    from miketalk.media.scratch import deferred_signals

    ran = []
    with handle_termination(), pytest.raises(KeyboardInterrupt) as raised:
        with deferred_signals():
            signal.getsignal(signum)(signum, None)  # the handler, as the main thread runs it
            ran.append("rest of the block")
    assert ran == ["rest of the block"]
    assert getattr(raised.value, "signum", signal.SIGINT) == signum


def test_ctrl_c_landing_in_a_forks_callback_is_asked_again() -> None:
    """Ctrl-C that lands while ``os.fork`` runs logging's callbacks (as the aligner's child
    is forked): raised there, it would be printed and lost ("Exception ignored in
    _releaseLock") and the build would go on; it is asked again once they are done."""
    import logging
    import sys
    import time

    from miketalk.console import handle_termination

    frames = []

    def profile(frame, event, _arg) -> None:
        if event == "call" and frame.f_code is logging._releaseLock.__code__:
            frames.append(frame)

    sys.setprofile(profile)
    try:
        logging._acquireLock()
        logging._releaseLock()
    finally:
        sys.setprofile(None)
    with handle_termination():
        signal.getsignal(signal.SIGINT)(signal.SIGINT, frames[0])  # returns: not lost there
        with pytest.raises(KeyboardInterrupt):
            for _ in range(3000):  # a poll's generous deadline (30 s)
                time.sleep(0.01)


def _failing_cli(monkeypatch: pytest.MonkeyPatch, failure: BaseException):
    """The CLI's entry module, with every subcommand raising ``failure``."""
    import argparse
    import importlib

    cli_main = importlib.import_module("miketalk.cli.main")

    def fail(_args: argparse.Namespace) -> int:
        raise failure

    parser = cli_main.build_parser()
    monkeypatch.setattr(
        parser, "parse_args", lambda _argv: argparse.Namespace(verbose=False, func=fail)
    )
    monkeypatch.setattr(cli_main, "build_parser", lambda: parser)
    return cli_main


@pytest.mark.parametrize(
    ("failure", "line"),
    [
        (OSError(28, "No space left on device", "/full/x.mp4"),
         "miketalk: error: no space left on the disk: /full/x.mp4"),
        (BrokenProcessPool("a child process terminated abruptly"),
         "miketalk: error: a worker process died"),
    ],
    ids=["disk-full", "worker-killed"],
)  # fmt: skip
def test_a_full_disk_or_a_killed_worker_is_one_line_not_a_traceback(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, failure: Exception, line: str
) -> None:
    cli_main = _failing_cli(monkeypatch, failure)
    assert cli_main.main(["phones", "x"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(line), err


def test_other_os_errors_are_one_line_and_their_traceback_is_there_with_v(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    """A file removed under a running build (the work folder deleted by hand, probed in
    issue 40) was a traceback; it is one line, exit 1 (the machine's or another program's
    doing), and ``-v`` shows where it happened."""
    gone = FileNotFoundError(2, "No such file or directory", "/m/miketalk-build-x/corpus")
    cli_main = _failing_cli(monkeypatch, gone)
    assert cli_main.main(["phones", "x"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "miketalk: error: No such file or directory: /m/miketalk-build-x/corpus (removed or "
        "changed while miketalk ran?); the output was not written"
    ]
    parser = cli_main.build_parser()
    monkeypatch.setattr(parser, "parse_args", lambda _argv: argparse.Namespace(
        verbose=True, func=lambda _a: (_ for _ in ()).throw(gone)))  # fmt: skip
    monkeypatch.setattr(cli_main, "build_parser", lambda: parser)
    assert cli_main.main(["phones", "x"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and err.strip().endswith("the output was not written")
