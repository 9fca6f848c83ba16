"""Coarticulation learned from the person's own speech (beyond the paper; its §10 limitation).

The paper's lip-sync (:mod:`miketalk.lipsync.timeline`) runs every transition from
one viseme image all the way to the next: each phone's viseme is reached in
full at the phone's middle, however short the phone. Real lips undershoot short
phones and anticipate the next one. This module replaces the piecewise-linear
path by the Cohen-Massaro dominance model (Cohen & Massaro 1993), whose
parameters are fitted to the recording, as the paper's successor learned its
trajectories from the recording (Ezzat, Geiger & Poggio 2002).

Model
-----
Keyframe ``i`` (one per phone at its middle, two for a diphthong; see
:func:`miketalk.lipsync.timeline.keyframes`) with viseme ``V_i`` at time ``c_i``
has the dominance

.. math:: D_i(t) = a_{V_i} \\exp(-\theta_{V_i} |t - (c_i - \\ell)|)

where ``a_V`` is the viseme's magnitude (how strongly it holds the mouth),
``theta_V`` its rate (1/s; how quickly its hold fades) and ``ell`` an
anticipation lead (s) common to all visemes: the mouth reaches for a phone's
viseme ``ell`` seconds before the phone's middle. Only keyframes within
``window`` seconds of ``t`` (and always the nearest one) count. The mouth at
``t`` is the blend of the visemes with weights ``w_i(t) = D_i(t) / sum_j D_j(t)``
(a viseme's weights summed over its keyframes). A short phone between two
dominant ones is then never reached in full: undershoot.

Fitting
-------
:func:`fit` takes the aligned phones of the training clips and the eigenlip
coordinates (:class:`miketalk.mouth.Eigenlips`) of their real
frames and of the viseme images, and chooses ``log a``, ``log theta`` and
``ell`` minimizing the squared distance between the predicted trajectory
``sum_V w_V(t) E(V)`` and the real one, each clip's trajectories with their
moving average over ``detrend`` seconds removed (:func:`detrender`): what
moves slower than that follows lighting and the head pose the stabilization
left rather than the mouth, and is not the model's to predict (fitted
without it, broad dominances of seconds fitted those drifts). ``ell`` is
chosen on a grid; for each grid value ``log a`` and ``log theta`` are found by
:func:`scipy.optimize.least_squares` (trust-region reflective, a finite-difference
Jacobian), kept in
plausible bounds, with a weak pull towards the prior ``a = 1``,
``theta = prior_rate`` so that a viseme seen rarely keeps the prior.
The training loss of the paper's own timeline (the same frames through
:func:`miketalk.lipsync.timeline.plan`) is stored beside the fitted one.

:func:`fit_coarticulation` runs it for a face built from clips and writes the
parameters as data (:func:`write_params`; a model keeps them as its
``coarticulation.json``); :func:`read_params` reads them back.

Rendering
---------
:func:`frame_weights` gives every frame of a timeline its visemes and weights,
the ``max_visemes`` largest, those under ``min_weight`` dropped, renormalized;
:func:`miketalk.draw.learned.render_learned` draws them.
"""

from importlib import import_module
from typing import TYPE_CHECKING, Any

from miketalk.draw.coarticulation.params import (
    FORMAT,
    LEAD_GRID,
    PRIOR_RATE,
    CoarticulationParams,
    read_params,
    write_params,
)

if TYPE_CHECKING:
    from miketalk.draw.coarticulation.fit import (
        TrainingClip,
        detrender,
        fit,
        fit_coarticulation,
        training_clips,
    )
    from miketalk.draw.coarticulation.weights import (
        dominance_weights,
        frame_weights,
        paper_trajectory,
        predict_trajectory,
    )

#: The names of the modules that need numpy, imported when first asked for: the parameters
#: (standard library only) are read before numpy loads (``miketalk say`` checks a model's
#: coarticulation before it starts Festival, :func:`miketalk.model.parts.choose_lipsync_model`).
_LAZY = {
    **dict.fromkeys(
        ("TrainingClip", "detrender", "fit", "fit_coarticulation", "training_clips"), "fit"
    ),
    **dict.fromkeys(
        ("dominance_weights", "frame_weights", "paper_trajectory", "predict_trajectory"),
        "weights",
    ),
}


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    where = _LAZY[name]
    module = import_module(f"{__name__}.{where}")
    for lazy in (n for n, w in _LAZY.items() if w == where):
        # every name of that module bound here: ``fit`` the function, not the submodule
        # ``fit`` that importing it bound in this package
        globals()[lazy] = getattr(module, lazy)
    return globals()[name]


__all__ = [
    "FORMAT",
    "LEAD_GRID",
    "PRIOR_RATE",
    "CoarticulationParams",
    "TrainingClip",
    "detrender",
    "dominance_weights",
    "fit",
    "fit_coarticulation",
    "frame_weights",
    "paper_trajectory",
    "predict_trajectory",
    "read_params",
    "training_clips",
    "write_params",
]
