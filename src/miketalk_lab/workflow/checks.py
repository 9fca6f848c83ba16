"""What the schema cannot check, checked before any job: a face's lip-sync and flow settings
go together, and its clips' (or its video's) files are all there.

Each problem is one line naming the face (and the clip); :func:`refuse` raises the first
few together.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from miketalk.corpus.clip_sources import read_transcripts
from miketalk.errors import MiketalkError, SettingError
from miketalk.flow.strategies import get_strategy
from miketalk_lab.workflow.config import ConfigError
from miketalk_lab.workflow.vocabulary import FITTED_MODELS

#: The library's names of the settings (:class:`~miketalk.errors.SettingError`) as the
#: config spells them.
CONFIG_NAMES = {"trajectory": "lipsync trajectory", "lipsync_model": "lipsync model"}


def check_lipsync(face: str, lipsync: Mapping, recording_model: str, from_clips: bool) -> None:
    """A face's lip-sync models: one fitted to clips needs a face built from clips, and a
    trajectory goes with the trained model (:func:`miketalk.lipsync.settings.check_trajectory`,
    the rule the command line's settings are checked by).

    Parameters
    ----------
    face : str
        The face's name.
    lipsync : Mapping
        Its lip-sync settings.
    recording_model : str
        The model of its utterances driven by a recording.
    from_clips : bool
        Whether it is built from clips (or one video of any speech).

    Raises
    ------
    ConfigError
        Naming the face and the setting.
    """
    from miketalk.lipsync.settings import check_trajectory

    for key, model in (("model", lipsync["model"]), ("recording_model", recording_model)):
        if model in FITTED_MODELS and not from_clips:
            raise ConfigError(
                f"faces.{face}: lipsync {key} {model!r} needs a face built from clips "
                "(it is fitted to their aligned frames)"
            )
    try:  # the library's rule (the command line's), named as the config's keys
        check_trajectory(lipsync["trajectory"], lipsync_model=lipsync["model"], recorded=False)
    except SettingError as err:
        raise ConfigError(f"faces.{face}: {err.render(CONFIG_NAMES)}") from None


def check_method(face: str, method: str, methods: Mapping) -> None:
    """A face's flow method is one of ``flow.methods``.

    Raises
    ------
    ConfigError
        Naming the configured ones.
    """
    if method not in methods:
        raise ConfigError(
            f"faces.{face}: flow method {method!r} is not in flow.methods ({', '.join(methods)})"
        )


def check_flow_methods(methods: Mapping[str, Mapping]) -> None:
    """Every flow method's estimator takes its settings: known names, values in range
    (:func:`miketalk.flow.registry.get_estimator` checks them), so that a wrong setting fails
    the dry run rather than the flows job.

    Raises
    ------
    ConfigError
        In one line naming the method, for the first that does not.
    """
    from miketalk.flow.registry import get_estimator

    for name, spec in methods.items():
        try:
            get_estimator(spec["estimator"], **spec.get("settings", {}))
        except MiketalkError as err:
            raise ConfigError(f"flow.methods.{name}: {err}") from None


def check_frame(face: str, settings: Mapping, *, from_clips: bool) -> None:
    """A face's frame (:class:`miketalk.building.frame.FrameSettings`): the crop frame for a
    face from clips (or from one video of any speech) only, a crop size with it only; no
    frame named is the face's own (:func:`~miketalk.building.frame.own_frame`).

    Raises
    ------
    ConfigError
        Naming the face and the key.
    """
    from miketalk.building.frame import CROP, FrameSettings, own_frame

    frame, size = settings["frame"], settings["crop_size"]
    if frame == CROP and not from_clips:
        raise ConfigError(
            f"faces.{face}: frame crop needs a face from clips or from one video of any speech "
            f"(corpus source clips, or video with media), not source {settings['corpus']['source']}"
        )
    try:
        # its rules, the command line's: named as the config's keys
        FrameSettings(own_frame(frame, of_person=from_clips), size)
    except MiketalkError as err:
        raise ConfigError(f"faces.{face}: {err}") from None


def check_face_settings(
    face: str,
    *,
    lipsync: Mapping,
    recording_model: str,
    from_clips: bool,
    method: str,
    strategy: str,
    methods: Mapping,
) -> None:
    """A face's settings go together: its strategy (:func:`get_strategy`), its lip-sync
    models (:func:`check_lipsync`), its flow method (:func:`check_method`), in that order.

    Parameters
    ----------
    face : str
        The face's name.
    lipsync : Mapping
        Its lip-sync settings (the config's, with its own overrides).
    recording_model : str
        The model of its utterances driven by a recording.
    from_clips : bool
        Whether it is built from clips (or one video of any speech).
    method, strategy : str
        Its model's flow method and strategy.
    methods : Mapping
        ``flow.methods``.

    Raises
    ------
    MiketalkError
        For an unknown strategy, naming the known ones.
    ConfigError
        For the first other problem.
    """
    get_strategy(strategy)
    check_lipsync(face, lipsync, recording_model, from_clips)
    check_method(face, method, methods)


def clip_path(pattern: str, clip: str) -> str:
    """A clip's file: ``pattern`` with its {id} filled in."""
    return pattern.replace("{id}", clip)


def clip_problems(face: str, corpus: Mapping) -> list[str]:
    """What is wrong with a face's clips, one line each naming the face and the clip.

    Parameters
    ----------
    face : str
        A face from clips.
    corpus : Mapping
        Its corpus settings, paths absolute.

    Returns
    -------
    list of str
        Empty when every clip's files are there.
    """
    where = f"faces.{face}.corpus"
    for key in ("media", "transcripts"):
        if not corpus[key]:
            return [f"{where}: a face from clips needs {key}"]
    for key in ("media", "timings"):
        if corpus[key] and "{id}" not in corpus[key]:
            return [f"{where}.{key} must contain {{id}}, got {corpus[key]!r}"]
    held_out = set(corpus["test"])
    problems = [
        f"{where}: clip {clip} is in both train and test (a held-out clip must never "
        "be read while building the model)"
        for clip in corpus["train"]
        if clip in held_out
    ]
    try:
        table = read_transcripts(corpus["transcripts"])
    except MiketalkError as err:
        return [*problems, f"{where}: {err}"]
    for split in ("train", "test"):
        for clip in corpus[split]:
            if clip not in table:  # a mistyped id: its files are missing too, unsaid
                problems.append(
                    f"{where}: clip {clip} ({split}) is not in the transcript table "
                    f"{corpus['transcripts']}"
                )
                continue
            if not Path(media := clip_path(corpus["media"], clip)).is_file():
                problems.append(f"{where}: clip {clip} ({split}): media file not found: {media}")
            timings = corpus["timings"] and clip_path(corpus["timings"], clip)
            if timings and not Path(timings).is_file():
                problems.append(
                    f"{where}: clip {clip} ({split}): word timing file not found: {timings}"
                )
    return problems


def video_problems(face: str, corpus: Mapping) -> list[str]:
    """What is wrong with a one-video face's files, one line each naming the face.

    Parameters
    ----------
    face : str
        A face from one video of any speech.
    corpus : Mapping
        Its corpus settings, paths absolute.

    Returns
    -------
    list of str
        Empty when its files are there and it lists no clips.
    """
    where = f"faces.{face}.corpus"
    problems = []
    for key in ("media", "transcript", "subtitles"):
        if corpus[key] and not Path(corpus[key]).is_file():
            problems.append(f"{where}.{key}: file not found: {corpus[key]}")
    if corpus["subtitles"] and Path(corpus["subtitles"]).suffix.lower() not in (".srt", ".vtt"):
        problems.append(f"{where}.subtitles must be .srt or .vtt: {corpus['subtitles']}")
    for key in ("train", "test", "timings", "transcripts"):
        if corpus[key]:
            problems.append(
                f"{where}.{key}: not for a face from one video (its utterances are found "
                "in it; heldout_seconds holds out its end)"
            )
    return problems


def refuse(problems: Sequence[str], shown: int = 5) -> None:
    """Raise the first ``shown`` problems together, one per line, and how many more.

    Raises
    ------
    ConfigError
        When there are any.
    """
    if problems:
        more = len(problems) - shown
        tail = [f"... and {more} more"] if more > 0 else []
        raise ConfigError("\n".join([*problems[:shown], *tail]))
