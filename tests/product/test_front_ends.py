"""The command line and the page make the same library call (:mod:`miketalk.api`): for the same
input and settings, ``miketalk say``/``dub`` and the page's work function
(:func:`miketalk.serve.work.speak`) write byte-identical mp4s, and refuse the same mistakes.

On the synthetic faces of ``test_cli`` (a shifted texture, exact flows) and ``test_dub`` (a
person's head whose motion is known, with its own background), and on s1 built from his video
(``s1_built``, slow): say typed text, say a recording, dub a video.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from test_cli import shifted_model
from test_dub import person, video  # noqa: F401 (its fixtures: a person's model, his video)

from miketalk import cli
from miketalk.cli.main import flag
from miketalk.errors import MiketalkError, SettingError
from miketalk.serve.work import speak
from miketalk.speech import FestivalBackend

ROOT = Path(__file__).resolve().parents[2]
TEXT = "Bin blue at F two now."

pytestmark = pytest.mark.skipif(
    not FestivalBackend().is_available(), reason="Festival not installed"
)


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return shifted_model(tmp_path_factory.mktemp("synthetic"), 64)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Festival's ``TEXT`` as a wav (``miketalk cues --wav``)."""
    wav = tmp_path_factory.mktemp("recording") / "speech.wav"
    assert cli.main(["cues", TEXT, "--wav", str(wav), "-o", str(wav.with_suffix(".tsv"))]) == 0
    return wav


def _cli(tmp_path: Path, *args: str) -> bytes:
    """The mp4 ``miketalk ARGS -o OUT`` writes."""
    out = tmp_path / "cli" / "out.mp4"
    out.parent.mkdir(exist_ok=True)
    assert cli.main([*args, "-o", str(out)]) == 0
    return out.read_bytes()


def _page(tmp_path: Path, model: Path, **job: object) -> bytes:
    """The mp4 the page's work function writes for the job ``job``."""
    folder = tmp_path / "page"
    folder.mkdir(exist_ok=True)
    outcome = speak(folder, model, **job)
    return outcome.files[outcome.result["video"]].read_bytes()


def _same(a: bytes, b: bytes) -> None:
    assert len(a) > 1000 and a == b


def test_say_text_is_the_same_from_both(synthetic: Path, tmp_path: Path) -> None:
    _same(
        _cli(tmp_path, "say", TEXT, "--model", str(synthetic)),
        _page(tmp_path, synthetic, text=TEXT),
    )


def test_say_text_with_its_settings_is_the_same_from_both(synthetic: Path, tmp_path: Path) -> None:
    cli_said = _cli(tmp_path, "say", TEXT, "--model", str(synthetic), "--voice", "ked",
                    "--lipsync-model", "paper")  # fmt: skip
    _same(cli_said, _page(tmp_path, synthetic, text=TEXT, voice="ked", lipsync="paper"))
    assert cli_said != _cli(tmp_path, "say", TEXT, "--model", str(synthetic))  # the voice told


def test_say_recording_is_the_same_from_both(
    synthetic: Path, recording: Path, tmp_path: Path
) -> None:
    _same(
        _cli(tmp_path, "say", "--audio", str(recording), "--text", TEXT, "--model", str(synthetic)),
        _page(tmp_path, synthetic, text=TEXT, audio=recording),
    )


def _dubbing(request: pytest.FixtureRequest) -> tuple[Path, Path]:
    """``test_dub``'s person (a model with its own background) and a video of him."""
    return request.getfixturevalue("person"), request.getfixturevalue("video")


def test_dub_is_the_same_from_both(request: pytest.FixtureRequest, tmp_path: Path) -> None:
    face, clip = _dubbing(request)
    _same(
        _cli(tmp_path, "dub", str(clip), "--text", "Bin blue.", "--model", str(face)),
        _page(tmp_path, face, text="Bin blue.", video=clip),
    )


def test_dub_of_a_recording_is_the_same_from_both(
    request: pytest.FixtureRequest, recording: Path, tmp_path: Path
) -> None:
    face, clip = _dubbing(request)
    _same(
        _cli(tmp_path, "dub", str(clip), "--audio", str(recording), "--text", TEXT,
             "--model", str(face)),
        _page(tmp_path, face, text=TEXT, audio=recording, video=clip),
    )  # fmt: skip


@pytest.mark.parametrize(
    ("face", "options", "job", "said"),
    [
        ("synthetic", [], {},
         "was not built from video of a person: dub needs a --model built from clips"),
        ("person", ["--lipsync-model", "learned"], {"lipsync": "learned"},
         "has no learned coarticulation"),
    ],
)  # fmt: skip
def test_both_refuse_the_same_dub_with_the_same_line(
    request: pytest.FixtureRequest, tmp_path: Path, capsys: pytest.CaptureFixture[str],
    face: str, options: list[str], job: dict, said: str,
) -> None:  # fmt: skip
    model, clip = request.getfixturevalue(face), _dubbing(request)[1]
    out = tmp_path / "cli.mp4"
    args = ["dub", str(clip), "--text", "Bin.", "--model", str(model), "-o", str(out)]
    assert cli.main([*args, *options]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    (tmp_path / "page").mkdir()
    with pytest.raises(MiketalkError) as page:
        speak(tmp_path / "page", model, text="Bin.", video=clip, **job)
    assert said in line
    rendered = page.value.render(flag) if isinstance(page.value, SettingError) else page.value
    assert line == f"miketalk: error: {rendered}"
    assert list(tmp_path.glob("*.mp4")) == [] and list((tmp_path / "page").iterdir()) == []


@pytest.mark.slow
def test_s1_says_and_dubs_the_same_from_both(s1_built: Path, tmp_path: Path) -> None:
    s1 = yaml.safe_load((ROOT / ".test" / "config.yaml").read_text())["faces"]["s1"]["corpus"]
    clip = ROOT / s1["media"].format(id="bbas3a")
    said = "bin blue at s three again"
    _same(
        _cli(tmp_path, "say", TEXT, "--model", str(s1_built)),
        _page(tmp_path, s1_built, text=TEXT),
    )
    _same(
        _cli(tmp_path, "say", "--audio", str(clip), "--text", said, "--model", str(s1_built)),
        _page(tmp_path, s1_built, text=said, audio=clip),
    )
    _same(
        _cli(tmp_path, "dub", str(clip), "--text", TEXT, "--model", str(s1_built)),
        _page(tmp_path, s1_built, text=TEXT, video=clip),
    )


@pytest.mark.slow
def test_a_face_crop_model_says_and_dubs_the_same_from_both(
    s1_crop_built: Path, tmp_path: Path
) -> None:
    """``miketalk build``'s default frame (conftest's ``s1_crop_built``): its say plays into
    the video's own frames at the video's rate (the page once drew it at the default rate),
    its dub at the dubbed video's."""
    from miketalk.api import BuildSettings

    model = s1_crop_built
    assert model.is_dir() and BuildSettings().frame == "crop"
    said = _cli(tmp_path, "say", TEXT, "--model", str(model))
    _same(said, _page(tmp_path, model, text=TEXT))
    clip = ROOT / "data" / "grid_s1" / "video" / "bbas3a.mpg"
    _same(
        _cli(tmp_path, "dub", str(clip), "--text", TEXT, "--model", str(model)),
        _page(tmp_path, model, text=TEXT, video=clip),
    )


def test_the_workflows_say_is_the_public_calls_with_its_morph_and_grouping(
    synthetic: Path, tmp_path: Path
) -> None:
    """Issue 49: the workflow's utterance rule called ``talk.say`` with its face's morph
    settings and viseme grouping; it now calls :func:`miketalk.api.say`
    (``SaySettings.grouping``, ``OpenModels(morph=...)``), with the bytes of the old call."""
    from miketalk import api
    from miketalk.lipsync.settings import LipsyncSettings
    from miketalk.model.face import open_model
    from miketalk.talk.say import say
    from miketalk.visemes import VisemeTable

    text, grouping, morph = "Think of this thin thing.", {"th": "f"}, {"median": False}
    with open_model(synthetic, morph_options=morph) as model:
        say(text, tmp_path / "old.mp4", model=model, table=VisemeTable(grouping=grouping),
            settings=LipsyncSettings(fps=30, max_px_per_frame=2.5, sampling="blur"))  # fmt: skip
    models = api.OpenModels(1, morph=morph)
    settings = api.SaySettings(model=synthetic, fps=30, max_px_per_frame=2.5, grouping=grouping)
    api.say(text, tmp_path / "new.mp4", settings, models=models)
    models.close()
    _same((tmp_path / "old.mp4").read_bytes(), (tmp_path / "new.mp4").read_bytes())
    plain = api.SaySettings(model=synthetic, fps=30, max_px_per_frame=2.5)
    api.say(text, tmp_path / "plain.mp4", plain, models=api.OpenModels(1, morph=morph))
    assert (tmp_path / "plain.mp4").read_bytes() != (tmp_path / "new.mp4").read_bytes()
