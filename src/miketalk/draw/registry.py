"""The one registry of lip-sync models: each name (:class:`~miketalk.lipsync.settings.LipsyncModel`)
to what draws its frames.

:func:`choose_lipsync_model` settles which model an utterance uses (the one asked for, else
the model's own) and checks that the model directory has it, reading only its small files;
:func:`open_drawing` reads what that lip-sync model needs and returns a :class:`Drawing`,
which :func:`miketalk.talk.utterance.write_utterance` asks for the frames.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from miketalk.errors import MiketalkError
from miketalk.lipsync.settings import LipsyncModel, resolve_lipsync_model
from miketalk.model.parts import lipsync_models_in, own_recording_model, trained_trajectories

if TYPE_CHECKING:
    import numpy as np

    from miketalk.draw.coarticulation import CoarticulationParams
    from miketalk.draw.trained import TrainedFace
    from miketalk.lipsync.motion import Weights
    from miketalk.lipsync.timeline import Timeline
    from miketalk.speech.acoustic import Recording


@dataclass(frozen=True)
class Drawing:
    """What draws an utterance's mouth: a lip-sync model with what it read from the model.

    Attributes
    ----------
    lipsync_model : LipsyncModel
        The model's name.
    coarticulation : CoarticulationParams or None
        ``learned``: the fitted coarticulation.
    trained : TrainedFace or None
        ``trained``: the trained face.
    trajectory : str or None
        ``trained``: its trajectory model, settled.
    """

    lipsync_model: LipsyncModel
    coarticulation: CoarticulationParams | None = None
    trained: TrainedFace | None = None
    trajectory: str | None = None

    @property
    def own_frames(self) -> bool:
        """Whether each frame is one of the person's own (no morph between visemes)."""
        return self.trained is not None

    def frames(
        self,
        model: Any,
        timeline: Timeline,
        *,
        recording: Recording | None = None,
        max_px_per_frame: float | None = None,
    ) -> tuple[Iterator[np.ndarray], Sequence[Weights] | None, Sequence[Weights] | None]:
        """The rendered frames of ``timeline`` (a closable iterator); for ``learned``, the
        viseme weights at each frame's middle and the states drawn, in order (several for a
        frame blurred to keep consecutive states within ``max_px_per_frame``,
        :func:`miketalk.draw.learned.learned_exposures`), which the motion is measured on;
        else None and None."""
        if self.trained is not None:
            from miketalk.draw.trained.draw import render_trained

            rendered = render_trained(
                model, timeline, trained=self.trained, kind=self.trajectory, recording=recording
            )
            return rendered, None, None
        if self.coarticulation is None:
            return model.render(timeline), None, None
        from miketalk.draw.coarticulation import frame_weights
        from miketalk.draw.learned import drawn_states, learned_exposures, render_learned

        middles = frame_weights(timeline, self.coarticulation)
        exposures = learned_exposures(
            timeline, self.coarticulation, displacement=model.displacement,
            max_px_per_frame=max_px_per_frame, middles=middles,
        )  # fmt: skip
        rendered = render_learned(model, timeline, self.coarticulation, exposures=exposures)
        return rendered, middles, drawn_states(exposures)

    def doc(self) -> dict:
        """What the utterance's JSON records of it."""
        doc: dict = {"lipsync_model": self.lipsync_model.value}
        return doc | ({"trajectory": self.trajectory} if self.trained is not None else {})


def _paper(model_dir: Path, trajectory: str | None, recorded: bool) -> Drawing:
    return Drawing(LipsyncModel.PAPER)


def _learned(model_dir: Path, trajectory: str | None, recorded: bool) -> Drawing:
    from miketalk.draw.coarticulation import read_params

    return Drawing(LipsyncModel.LEARNED, coarticulation=read_params(model_dir))


def _trained(model_dir: Path, trajectory: str | None, recorded: bool) -> Drawing:
    from miketalk.draw.trained import read_trained

    trained = read_trained(model_dir)
    kind = trained.kind_for(trajectory, recorded=recorded)
    return Drawing(LipsyncModel.TRAINED, trained=trained, trajectory=kind)


#: Each lip-sync model's name -> what opens its drawing from a model directory.
DRAWERS: dict[LipsyncModel, Callable[[Path, str | None, bool], Drawing]] = {
    LipsyncModel.PAPER: _paper,
    LipsyncModel.LEARNED: _learned,
    LipsyncModel.TRAINED: _trained,
}


def choose_lipsync_model(
    model_dir: str | os.PathLike[str],
    requested: str | None,
    *,
    trajectory: str | None = None,
    recorded: bool,
) -> LipsyncModel:
    """The lip-sync model of an utterance with the model in ``model_dir``: ``requested``, else
    the model's own (:func:`~miketalk.lipsync.settings.resolve_lipsync_model`), checked
    against the directory by its small files alone (before Festival or numpy start).

    Raises
    ------
    MiketalkError
        In one line: a setting that does not fit (see ``resolve_lipsync_model``), a model
        without the learned coarticulation or the trained face asked for, a trained face
        without the trajectory asked for.
    """
    directory = Path(model_dir)
    if requested is None and trajectory is None and recorded:
        requested = own_recording_model(directory)
    chosen = resolve_lipsync_model(
        requested, available=lipsync_models_in(directory), trajectory=trajectory,
        recorded=recorded,
    )  # fmt: skip
    if chosen == LipsyncModel.LEARNED:
        from miketalk.draw.coarticulation import read_params

        read_params(directory)  # the one-line error of a model without it
    elif chosen == LipsyncModel.TRAINED:
        kinds = trained_trajectories(directory)
        if not kinds:
            from miketalk.draw.trained.build import read_trained

            read_trained(directory)  # the one-line error of a model without it
        if trajectory is not None and trajectory not in kinds:
            raise MiketalkError(
                f"the trained face in {directory} has no {trajectory} trajectory (fitted "
                "before it existed: rebuild the model)"
            )
    return chosen


def open_drawing(
    model_dir: str | os.PathLike[str],
    lipsync_model: str | None,
    *,
    trajectory: str | None = None,
    recorded: bool,
) -> Drawing:
    """What draws an utterance of the model in ``model_dir`` with ``lipsync_model`` (None: the
    model's own) and ``trajectory``: the registry's entry (:data:`DRAWERS`), opened.

    Raises
    ------
    MiketalkError
        In one line, as :func:`choose_lipsync_model`, or for a malformed model part.
    """
    if lipsync_model is None and trajectory is None and recorded:
        lipsync_model = own_recording_model(model_dir)
    chosen = resolve_lipsync_model(
        lipsync_model, available=lipsync_models_in(model_dir), trajectory=trajectory,
        recorded=recorded,
    )  # fmt: skip
    return DRAWERS[chosen](Path(model_dir), trajectory, recorded)


__all__ = ["DRAWERS", "Drawing", "choose_lipsync_model", "open_drawing"]
