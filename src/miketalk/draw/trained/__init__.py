"""The trained talking face (beyond the paper): every training frame, a trajectory, a selection.

MikeTalk (1999) speaks with 16 viseme images and straight transitions between
them. Its successor (Ezzat, Geiger & Poggio 2002) learned the mouth's
trajectories from all of the recording, and trajectory-guided sample selection
(Wang et al. 2010) draws every frame from the person's own frames along such a
trajectory. This package does both for a face built from clips:

:mod:`~miketalk.draw.trained.mouths`
    every training frame measured: the principal components of its grey mouth
    region (its *description*), and its colour mouth patch kept to draw with;
:mod:`~miketalk.draw.trained.training`
    the training clips as the trajectory models see them (phones, frame times,
    descriptions, recordings) and the settings they are fitted with;
:mod:`~miketalk.draw.trained.trajectory`
    three trajectory models to the description, fitted to all training frames:
    a ridge regression over a window of phone context (``window``), MMM-style
    regularized trajectories (``regularized``), and the window regression that
    also hears the recording (``heard``, :mod:`miketalk.speech.acoustic`);
:mod:`~miketalk.draw.trained.selection`
    a Viterbi search over the training frames along the predicted trajectory
    (target cost: distance to the prediction; join cost: visual distance,
    nothing for frames consecutive in the recording), the chosen patches
    composited onto the face with a feathered mask, joins morphed;
:mod:`~miketalk.draw.trained.build`
    :func:`fit_trained` (the workflow's model rule) and :func:`read_trained`;
:mod:`~miketalk.draw.trained.draw`
    :func:`~miketalk.draw.trained.draw.render_trained`: a timeline's frames.

The lip-sync model is ``trained`` (``say --lipsync-model trained``).
"""

from miketalk.draw.trained.build import TrainedFace, fit_trained, read_trained

__all__ = ["TrainedFace", "fit_trained", "read_trained"]
