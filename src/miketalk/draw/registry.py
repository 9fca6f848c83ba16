"""The one registry of lip-sync models: each name (:class:`~miketalk.lipsync.settings.LipsyncModel`)
to what draws its frames.

Each entry of :data:`DRAWERS` opens its :class:`Drawing` from the parts the model gives
(:class:`miketalk.model.face.Model`: its coarticulation, its trained face);
:func:`open_drawing` settles which lip-sync model an utterance uses (the one asked for,
else the model's own) and asks the registry for it, and
:func:`miketalk.talk.frames.draw_utterance` asks the drawing for the frames. What
differs between the lip-sync models lives in their drawings, not in a choice made
elsewhere.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from miketalk.lipsync.settings import LipsyncModel, resolve_lipsync_model

if TYPE_CHECKING:
    import numpy as np

    from miketalk.draw.coarticulation import CoarticulationParams
    from miketalk.draw.trained import TrainedFace
    from miketalk.lipsync.motion import Weights
    from miketalk.lipsync.timeline import Timeline
    from miketalk.speech.acoustic import Recording

#: What :meth:`Drawing.frames` returns: the rendered frames (a closable iterator); the viseme
#: weights at each frame's middle and the states drawn (the learned coarticulation's, which
#: the motion is measured on), else None and None.
#: Frames before a sentence's end, past the coarticulation's window, that a keyframe after
#: it may still change through the step limit's blur (:meth:`LearnedDrawing.settled`).
SETTLE_FRAMES = 6

Frames = tuple["Iterator[np.ndarray]", "Sequence[Weights] | None", "Sequence[Weights] | None"]


@dataclass(frozen=True)
class Drawing:
    """What draws an utterance's mouth: a lip-sync model with what it read from the model;
    this one the paper's (every transition from one viseme image all the way to the next).

    Attributes
    ----------
    lipsync_model : LipsyncModel
        The model's name (a class attribute of each drawing).
    own_frames : bool
        Whether each frame is one of the person's own (no morph between visemes).
    """

    lipsync_model: ClassVar[LipsyncModel] = LipsyncModel.PAPER
    own_frames: ClassVar[bool] = False

    @property
    def trajectory(self) -> str | None:
        """``trained``: its trajectory model, settled; else None."""
        return None

    def settled(self, timeline: Timeline) -> int:
        """How many of ``timeline``'s first frames the keyframes of a sentence after it
        (:func:`miketalk.talk.sentences.in_context`) cannot change: what may be drawn before
        that sentence is known. All of them here (the paper's morph and the trained face
        read no keyframes)."""
        return len(timeline.frames)

    def frames(
        self,
        model: Any,
        timeline: Timeline,
        *,
        recording: Recording | None = None,
        max_px_per_frame: float | None = None,
        region: tuple[int, int, int, int] | None = None,
        part: tuple[int, int] | None = None,
    ) -> Frames:
        """The frames of ``timeline`` drawn with ``model`` (see :data:`Frames`); ``region``
        ``(x0, y0, x1, y1)``: only these pixels of each frame will be read (a frame
        composited into video), which a drawing may draw alone. ``part`` ``(lo, hi)``: only
        frames ``lo`` to ``hi`` (a drawing whose :meth:`settled` is every frame is asked
        for its whole only)."""
        _whole(timeline, part)
        return model.render(timeline), None, None

    def doc(self) -> dict:
        """What the utterance's JSON records of it."""
        return {"lipsync_model": self.lipsync_model.value}


@dataclass(frozen=True)
class LearnedDrawing(Drawing):
    """The model's learned coarticulation (:mod:`miketalk.draw.coarticulation`)."""

    lipsync_model: ClassVar[LipsyncModel] = LipsyncModel.LEARNED
    coarticulation: CoarticulationParams

    def frames(
        self,
        model: Any,
        timeline: Timeline,
        *,
        recording: Recording | None = None,
        max_px_per_frame: float | None = None,
        region: tuple[int, int, int, int] | None = None,
        part: tuple[int, int] | None = None,
    ) -> Frames:
        """The frames, with the viseme weights at each frame's middle and the states drawn,
        in order (several for a frame blurred to keep consecutive states within
        ``max_px_per_frame``, :func:`miketalk.draw.learned.learned_exposures`); ``part``
        ``(lo, hi)``: frames ``lo`` to ``hi`` only, weighed and blurred as in the whole."""
        from miketalk.draw.coarticulation import frame_weights
        from miketalk.draw.learned import drawn_states, learned_exposures, render_learned

        middles = frame_weights(timeline, self.coarticulation)
        exposures = learned_exposures(
            timeline, self.coarticulation, displacement=model.displacement,
            max_px_per_frame=max_px_per_frame, middles=middles,
        )  # fmt: skip
        if part is not None:
            middles, exposures = middles[part[0] : part[1]], exposures[part[0] : part[1]]
        rendered = render_learned(
            model, timeline, self.coarticulation, exposures=exposures, region=region
        )
        return rendered, middles, drawn_states(exposures)

    def settled(self, timeline: Timeline) -> int:
        """The frames further than the coarticulation's window (and :data:`SETTLE_FRAMES`
        more, the step limit's blur reaching back) before ``timeline``'s end: a keyframe
        after the end weighs no frame further than the window, and the blur of
        :func:`~miketalk.draw.learned.learned_exposures` spreads a change a few frames
        (7 frames before the end at most on s1's sentences, the window being 10.5)."""
        end = timeline.duration - self.coarticulation.window - SETTLE_FRAMES / timeline.fps
        return sum(1 for f in timeline.frames if f.time < end)


@dataclass(frozen=True)
class TrainedDrawing(Drawing):
    """The person's own frames along the trained face's trajectory
    (:mod:`miketalk.draw.trained`)."""

    lipsync_model: ClassVar[LipsyncModel] = LipsyncModel.TRAINED
    own_frames: ClassVar[bool] = True
    trained: TrainedFace
    kind: str

    @property
    def trajectory(self) -> str:
        """Its trajectory model, settled (:meth:`~miketalk.draw.trained.TrainedFace.kind_for`)."""
        return self.kind

    def frames(
        self,
        model: Any,
        timeline: Timeline,
        *,
        recording: Recording | None = None,
        max_px_per_frame: float | None = None,
        region: tuple[int, int, int, int] | None = None,
        part: tuple[int, int] | None = None,
    ) -> Frames:
        """The frames drawn from the person's own (``recording``: the sound the trajectory
        may hear; ``max_px_per_frame`` does not apply)."""
        from miketalk.draw.trained.draw import render_trained

        _whole(timeline, part)
        rendered = render_trained(
            model, timeline, trained=self.trained, kind=self.kind, recording=recording
        )
        return rendered, None, None

    def doc(self) -> dict:
        """What the utterance's JSON records of it: also its trajectory."""
        return super().doc() | {"trajectory": self.kind}


def _whole(timeline: Timeline, part: tuple[int, int] | None) -> None:
    """Refuse a ``part`` that is not the whole of ``timeline`` (a drawing that draws only
    whole utterances)."""
    if part is not None and tuple(part) != (0, len(timeline.frames)):
        raise ValueError(f"this drawing draws whole utterances, not frames {part}")


def _paper(model: Any, trajectory: str | None, recorded: bool) -> Drawing:
    return Drawing()


def _learned(model: Any, trajectory: str | None, recorded: bool) -> Drawing:
    return LearnedDrawing(model.coarticulation)


def _trained(model: Any, trajectory: str | None, recorded: bool) -> Drawing:
    trained = model.trained_face
    return TrainedDrawing(trained, trained.kind_for(trajectory, recorded=recorded))


#: Each lip-sync model's name -> what opens its drawing from a model
#: (:class:`miketalk.model.face.Model`), the trajectory asked for and whether a recording
#: drives the utterance.
DRAWERS: dict[LipsyncModel, Callable[[Any, str | None, bool], Drawing]] = {
    LipsyncModel.PAPER: _paper,
    LipsyncModel.LEARNED: _learned,
    LipsyncModel.TRAINED: _trained,
}


def open_drawing(
    model: Any,
    lipsync_model: str | None,
    *,
    trajectory: str | None = None,
    recorded: bool,
) -> Drawing:
    """What draws an utterance of ``model`` with ``lipsync_model`` (None: the model's own, its
    :attr:`~miketalk.model.face.Model.own_recording_model` for a recording, else the first
    preferred among its :attr:`~miketalk.model.face.Model.lipsync_models`) and
    ``trajectory``: the registry's entry (:data:`DRAWERS`), opened with the model's part.

    Raises
    ------
    MiketalkError
        In one line: a setting that does not fit
        (:func:`~miketalk.lipsync.settings.resolve_lipsync_model`), a model without the part
        the lip-sync model needs, or a malformed part.
    """
    if lipsync_model is None and trajectory is None and recorded:
        lipsync_model = model.own_recording_model
    chosen = resolve_lipsync_model(
        lipsync_model, available=model.lipsync_models, trajectory=trajectory, recorded=recorded
    )
    return DRAWERS[chosen](model, trajectory, recorded)


__all__ = ["DRAWERS", "Drawing", "LearnedDrawing", "TrainedDrawing", "open_drawing"]
