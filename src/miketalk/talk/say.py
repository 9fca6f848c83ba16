"""Text in, talking-face video out: speech, lip-sync, morphing, mp4.

:func:`say` writes two files: ``NAME.mp4`` and, beside it, ``NAME.json``, the
timeline of its frames and the measures of its motion
(:mod:`miketalk.lipsync.motion`). They are replaced together or not at all
(:func:`miketalk.media.atomic.atomic_paths`): on any failure, Ctrl-C or
SIGTERM included, an older pair is left as it was, and a run killed outright
leaves nothing the next run does not tidy. The output is checked before any
work (:func:`check_output`), and so are the settings.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import asdict
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.lipsync.sampling import speak_in_sync
from miketalk.lipsync.settings import LipsyncModel, Sampling, check_settings, check_trajectory
from miketalk.lipsync.timeline import Timeline, keyframes
from miketalk.model.face import Model
from miketalk.model.parts import default_model_dir
from miketalk.speech.backend import PendingSpeech, SpeechBackend, get_backend
from miketalk.speech.types import Phone, Utterance
from miketalk.talk.output import check_output
from miketalk.talk.utterance import Spoken, write_utterance
from miketalk.visemes import VisemeTable, default_table

if TYPE_CHECKING:  # numpy loads after Festival has started (`miketalk say`)
    from miketalk.composite.background import Background
    from miketalk.draw.coarticulation import CoarticulationParams


log = logging.getLogger(__name__)


#: The default sampling of transitions too fast for ``max_px_per_frame``.
DEFAULT_SAMPLING: Sampling = "blur"


def open_model(directory: str | os.PathLike[str] | None, **options: object) -> Model:
    """Open a model, with a hint on how to build the default one when it is missing."""
    path = Path(directory) if directory is not None else default_model_dir()
    if not (path / "manifest.json").exists():
        hint = (
            "build the default model with `make run` (or `snakemake --cores all model`)"
            if directory is None
            else "pass --model with a directory built by the workflow"
        )
        raise MiketalkError(f"no model at {path}: {hint}")
    return Model(path, **options)


def say(
    text: str | PendingSpeech,
    output: str | os.PathLike[str],
    *,
    model: Model,
    fps: float = defaults.FPS,
    max_px_per_frame: float | None = defaults.MAX_PX_PER_FRAME,
    sampling: Sampling = DEFAULT_SAMPLING,
    max_slowdown: float | None = None,
    lipsync_model: LipsyncModel = defaults.LIPSYNC_MODEL,
    trajectory: str | None = None,
    backend: SpeechBackend | None = None,
    table: VisemeTable | None = None,
    progress: bool = False,
    overwrite: bool = False,
    background: Background | None = None,
) -> tuple[Utterance, Timeline]:
    """Speak ``text`` as an mp4 at ``output``, with its timeline JSON beside it.

    :func:`speak` with the same arguments; returns its utterance and timeline.
    """
    spoken = speak(
        text, output, model=model, fps=fps, max_px_per_frame=max_px_per_frame,
        sampling=sampling, max_slowdown=max_slowdown, lipsync_model=lipsync_model,
        trajectory=trajectory, backend=backend, table=table, progress=progress,
        overwrite=overwrite, background=background,
    )  # fmt: skip
    return spoken.utterance, spoken.timeline


def speak(
    text: str | PendingSpeech,
    output: str | os.PathLike[str],
    *,
    model: Model,
    fps: float = defaults.FPS,
    max_px_per_frame: float | None = defaults.MAX_PX_PER_FRAME,
    sampling: Sampling = DEFAULT_SAMPLING,
    max_slowdown: float | None = None,
    lipsync_model: LipsyncModel = defaults.LIPSYNC_MODEL,
    trajectory: str | None = None,
    backend: SpeechBackend | None = None,
    table: VisemeTable | None = None,
    progress: bool = False,
    overwrite: bool = False,
    background: Background | None = None,
) -> Spoken:
    """Speak ``text`` as an mp4 at ``output``, with its timeline JSON beside it.

    The JSON (``output`` with suffix ``.json``) is :meth:`Timeline.to_dict`
    plus ``format`` (:data:`TIMELINE_FORMAT`), ``text``, ``sampling``,
    ``max_px_per_frame``, ``max_slowdown``, ``planned_phones`` (the phones
    the engine predicted, before the paper's mode lengthened any),
    ``planned_duration``, ``largest_step_px`` and ``motion``
    (:class:`~miketalk.lipsync.motion.Motion`); :func:`read_said` reads it back.
    It is strict JSON (no NaN).

    Parameters
    ----------
    text : str or PendingSpeech
        The text, or its synthesis already started with ``backend.start(text)``
        (the engine then analyses the text while the caller loads the model;
        ``say`` finishes or closes it).
    output : path-like
        The ``.mp4`` to write.
    model : Model
        The visemes and their flows.
    fps : float
        Frame rate, in :data:`~miketalk.lipsync.timeline.FPS_RANGE`.
    max_px_per_frame : float or None
        The largest step between consecutive morphs, in
        :data:`~miketalk.lipsync.timeline.MAX_PX_RANGE`; None: no limit (as
        ``sampling="none"``).
    sampling : {"blur", "paper", "none"}
        How transitions too fast for the limit are sampled
        (:mod:`miketalk.lipsync.timeline`): ``"blur"`` (default) keeps the speech's
        own duration and renders more morphs than frames, each frame their
        average; ``"paper"`` lengthens the speech (paper §7); ``"none"``
        renders one morph per frame.
    max_slowdown : float, optional
        With ``sampling="paper"``: the speech may become at most this many
        times longer than the engine's own timing (what is then still too fast
        is blurred). None: no cap, as in the paper.
    lipsync_model : {"paper", "learned", "trained"}
        How the mouth moves (:data:`miketalk.defaults.LIPSYNC_MODEL`):
        ``"paper"`` draws each frame on the transition from one viseme to the
        next; ``"learned"`` draws each frame's point between several visemes
        from the coarticulation fitted into the model
        (:func:`miketalk.draw.coarticulation.frame_weights`, drawn by
        :mod:`miketalk.render.multimorph`) at the frame's middle: ``sampling`` then
        sets only the speech's duration (blur's extra morphs are not drawn;
        the learned path is smooth of itself); ``"trained"`` draws each frame
        from his own frames along a trained trajectory (:mod:`miketalk.draw.trained`).
    trajectory : str, optional
        With ``"trained"``: its trajectory model (default the face's; ``heard`` listens to
        a recording, which synthesized speech is not, and is refused here).
    backend : SpeechBackend, optional
        The engine for a ``str`` text (default Festival).
    table : VisemeTable, optional
        Phone-to-viseme table (default: the paper's).
    progress : bool
        Draw a progress bar on stderr.
    overwrite : bool
        Replace a ``NAME.json`` that is not a miketalk timeline.
    background : Background, optional
        Frames of the person the mouth is composited into
        (:mod:`miketalk.composite.background`); None: the model's still face.

    Returns
    -------
    Spoken
        The audio actually used, the timeline of the frames, the measures of
        the motion and the files written.

    Raises
    ------
    MiketalkError
        A bad setting or output (before anything runs), a model without the
        learned coarticulation ``lipsync_model`` asks for, nothing speakable,
        a failing engine or model.
    """
    started = time.perf_counter()
    speech: PendingSpeech | None = text if isinstance(text, PendingSpeech) else None
    try:
        check_settings(
            fps=fps, max_px_per_frame=max_px_per_frame, sampling=sampling,
            max_slowdown=max_slowdown, lipsync_model=lipsync_model,
        )  # fmt: skip
        coarticulation = learned_coarticulation(model) if lipsync_model == "learned" else None
        trained = None
        if lipsync_model == "trained":  # one line for a model without a trained face
            from miketalk.draw.trained import read_trained

            trained = read_trained(model.directory)
            trajectory = trained.kind_for(trajectory, recorded=False)
        check_trajectory(trajectory, lipsync_model=lipsync_model, recorded=False)
        output = check_output(output, overwrite=overwrite)
        if speech is None:
            speech = (backend or get_backend("festival")).start(str(text))
    except BaseException:
        if speech is not None:
            speech.close()
        raise
    planned: list[tuple[Phone, ...]] = []
    table = table or default_table()

    def on_planned(phones: tuple[Phone, ...]) -> None:
        # retiming changes when visemes are shown, never which: the flows the
        # render needs are read while the engine makes the wave
        planned.append(phones)
        keys = keyframes(phones, table)
        model.prefetch((a.viseme, b.viseme) for a, b in pairwise(keys))

    with speech:
        utterance, timeline = speak_in_sync(
            speech,
            table,
            fps=fps,
            displacement=model.displacement,
            max_px_per_frame=max_px_per_frame,
            sampling=sampling,
            max_slowdown=max_slowdown,
            on_planned=on_planned,
        )
    # A voice that sets its own durations (HTS) speaks other times than it planned:
    # unless the paper's mode dictated them, the phones as spoken are the natural ones.
    lengthened = sampling == "paper" and max_px_per_frame is not None
    planned_phones = planned[-1] if planned and lengthened else utterance.phones
    planned_duration = round(planned_phones[-1].end * utterance.rate) / utterance.rate
    log.info(
        "speech: %.2f s (%.2f s at its own timing), %d phones; %d frames, %d morphs",
        utterance.duration, planned_duration, len(utterance.phones), len(timeline.frames),
        timeline.morph_count,
    )  # fmt: skip
    motion = write_utterance(
        output,
        model=model,
        timeline=timeline,
        samples=utterance.samples,
        rate=utterance.rate,
        natural_duration=planned_duration,
        extra={
            "text": utterance.text,
            "sampling": sampling if max_px_per_frame is not None else "none",
            "max_px_per_frame": max_px_per_frame,
            "max_slowdown": max_slowdown,
            "lipsync_model": lipsync_model,
            "planned_phones": [asdict(p) for p in planned_phones],
            # the wav ends on the sample nearest the last phone's end (Utterance's invariant)
            "planned_duration": planned_duration,
        }
        | ({"trajectory": trajectory} if trained is not None else {})
        | _background_doc(background),
        coarticulation=coarticulation,
        trained=trained,
        trajectory=trajectory,
        progress=progress,
        overwrite=overwrite,
        background=background,
    )
    log.info("speak took %.2f s", time.perf_counter() - started)
    return Spoken(utterance, timeline, motion, output, output.with_suffix(".json"))


def _background_doc(background: Background | None) -> dict:
    from miketalk.composite.background import background_doc

    return background_doc(background)


def learned_coarticulation(model: Model) -> CoarticulationParams:
    """The learned coarticulation fitted into ``model``'s directory.

    Raises
    ------
    MiketalkError
        One line, when the model has none (a model built from a synthetic
        face, or before coarticulation was fitted): use the paper's lip-sync.
    """
    from miketalk.draw.coarticulation import read_params

    return read_params(model.directory)
