"""``build``: a talking-face model from one video of a person and what it says.

The workflow's stages for a face from one video run one after the other
(:func:`miketalk.building.from_video.build_model_from_video`) in a folder beside the model's,
removed at the end; the model's folder appears only when the model is complete.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

from miketalk.api.results import BuildResult
from miketalk.api.settings import BuildSettings
from miketalk.errors import SettingError

__all__ = ["build", "list_model_files", "sweep_build"]


def build(
    video: str | os.PathLike[str],
    output: str | os.PathLike[str],
    settings: BuildSettings | None = None,
    *,
    transcript: str | os.PathLike[str] | None = None,
    subtitles: str | os.PathLike[str] | None = None,
    progress: bool = False,
    report: Callable[[str, float, float], object] | None = None,
) -> BuildResult:
    """Build a model at ``output`` from ``video`` and what it says (its ``transcript``, a
    plain text file, or its ``subtitles``, .srt or .vtt: one of them, or neither: its words
    are recognized, :mod:`miketalk.corpus.heard_script`).

    Parameters
    ----------
    video : path-like
        A video of one person talking, face to the camera.
    output : path-like
        The model's directory (replaces an older model only with ``settings.overwrite``).
    settings : BuildSettings, optional
        The frame the face is built in, what is held out, the processes.
    transcript, subtitles : path-like, optional
        What the video says.
    progress : bool
        Draw a progress bar naming the running stage on stderr.
    report : callable, optional
        ``report(stage, seconds, peak_mb)``, after each stage.

    Returns
    -------
    BuildResult

    Raises
    ------
    MiketalkError
        In one line, before the long work where it can be: no video or no sound, no face or
        several, no speech, a transcript in another language or of another video, too little
        speech for the viseme classes.
    """
    from miketalk.building.from_video import build_model_from_video

    settings = settings if settings is not None else BuildSettings()
    if transcript is not None and subtitles is not None:  # neither: its words are recognized
        raise SettingError("give the video's {transcript} or its {subtitles}, not both")
    seconds = build_model_from_video(
        video, output, transcript=transcript, subtitles=subtitles,
        heldout_seconds=settings.heldout_seconds, workers=settings.workers,
        force=settings.overwrite, progress=progress, report=report,
        keep_corpus=settings.keep_corpus, crop=settings.frame_settings.crop,
        flow=settings.flow, mixed_window=settings.mixed_window,
    )  # fmt: skip
    from miketalk.model.parts import built_choice, default_lipsync_model, trained_predicts

    segments = json.loads((Path(output) / "build" / "segments.json").read_text("utf-8"))
    utterances = segments["utterances"]
    choice = built_choice(output) or {}
    return BuildResult(
        Path(output),
        utterances=sum(u["split"] == "train" for u in utterances),
        held_out=sum(u["split"] == "test" for u in utterances),
        words=segments["words"],
        unaligned_words=len(segments["unaligned"]),
        stage_seconds=dict(seconds),
        recording_lipsync=default_lipsync_model(output, recorded=True),
        trained_cv_r2=trained_predicts(output)[1],
        lipsync_scores=dict(choice.get("scores", {})),
        lipsync_reason=str(choice.get("reason", "")),
    )


def sweep_build(output: str | os.PathLike[str]) -> None:
    """Remove what a build killed outright left beside the model's folder ``output`` (its work
    folder; :func:`miketalk.media.scratch.sweep_scratch`)."""
    from miketalk.media.scratch import sweep_scratch

    sweep_scratch(Path(output).parent)


def list_model_files(model_dir: str | os.PathLike[str]) -> int:
    """List a file a front end wrote into the model at ``model_dir`` (its label) as one of
    the model's own (:func:`miketalk.model.write.list_model_files`); how many were added."""
    from miketalk.model.write import list_model_files as listed

    return listed(model_dir)
