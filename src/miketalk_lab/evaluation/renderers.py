"""What the held-out evaluation renders: each ``(model, timeline) -> frames``, baselines too.

The paper's morph, the still face (the silence viseme held), the flip-book (the
nearest viseme held), the cross-dissolve with the morph's alpha, and the models a
face has learned (``learned``, ``trained``, ``trained_regularized``,
``trained_previous``, ``trained_heard``, ``trained_pooled``). Each is ``(model, timeline,
recording)``: the recording that drives the timeline, which only ``trained_heard`` and
``trained_pooled`` hear.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from miketalk.lipsync.timeline import Timeline
from miketalk.model.face import Model
from miketalk.speech.acoustic import Recording
from miketalk.visemes import SILENCE


def _pairs(model: Model, timeline: Timeline) -> Iterator[tuple[str, str, float]]:
    for sample in timeline.frames:
        t = timeline.transitions[sample.transition]
        yield t.source, t.target, sample.alpha


def render_still(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The silence viseme held: a face that does not speak."""
    image = model.image(SILENCE)
    for _ in timeline.frames:
        yield image


def render_flipbook(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The nearest viseme held, no morph: ``alpha < 0.5`` shows the source, else the target."""
    for a, b, alpha in _pairs(model, timeline):
        yield model.image(a if alpha < 0.5 else b)


def render_dissolve(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """A cross-dissolve with the morph's alpha: ``(1 - alpha) A + alpha B``, no flow."""
    for a, b, alpha in _pairs(model, timeline):
        blend = (1.0 - alpha) * model.image(a).astype(np.float32) + alpha * model.image(b).astype(
            np.float32
        )
        yield np.clip(blend + 0.5, 0, 255).astype(np.uint8)


def render_morph(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The paper's morph (what ``miketalk say`` renders)."""
    return model.render(timeline)


def render_learned(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """Learned coarticulation (:mod:`miketalk.draw.coarticulation`) drawn by the N-way morph."""
    from miketalk.draw.learned import render_model_learned

    return render_model_learned(model, timeline)


def render_trained(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The trained face (:mod:`miketalk.draw.trained`): his frames along its default trajectory."""
    from miketalk.draw.trained.draw import render_trained as render

    return render(model, timeline)


def render_trained_regularized(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The trained face with the MMM-style regularized trajectory (the other trajectory model)."""
    from miketalk.draw.trained.draw import render_trained as render

    return render(model, timeline, kind="regularized")


def render_trained_previous(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The trained face with the selection settings it had before they were chosen by
    cross-validation on the training clips
    (:data:`miketalk.draw.trained.selection.PREVIOUS_SELECTION`), for a paired comparison."""
    from miketalk.draw.trained.draw import render_trained as render
    from miketalk.draw.trained.selection import PREVIOUS_SELECTION

    return render(model, timeline, selection=PREVIOUS_SELECTION)


def render_trained_heard(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The trained face along the ``heard`` trajectory: the phones and the recording."""
    from miketalk.draw.trained.draw import render_trained as render

    return render(model, timeline, kind="heard", recording=recording)


def render_trained_pooled(
    model: Model, timeline: Timeline, recording: Recording | None = None
) -> Iterator[np.ndarray]:
    """The trained face along the ``pooled`` trajectory: the person-independent model of
    the mouth's motion adapted to it (:mod:`miketalk.draw.trained.pooled`)."""
    from miketalk.draw.trained.draw import render_trained as render

    return render(model, timeline, kind="pooled", recording=recording)


#: Renderers of a timeline, by the name the tables use.
RENDERERS: dict[str, Callable[..., Iterator[np.ndarray]]] = {
    "still": render_still,
    "flipbook": render_flipbook,
    "dissolve": render_dissolve,
    "morph": render_morph,
    "learned": render_learned,
    "trained": render_trained,
    "trained_regularized": render_trained_regularized,
    "trained_previous": render_trained_previous,
    "trained_heard": render_trained_heard,
    "trained_pooled": render_trained_pooled,
}
