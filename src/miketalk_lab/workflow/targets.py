"""What the workflow makes: the default target's files, and the lists of files the tables and
figures gather (their inputs, known when the workflow is read).
"""

from __future__ import annotations

from miketalk_lab.workflow import paths
from miketalk_lab.workflow.experiment import Experiment
from miketalk_lab.workflow.vocabulary import DIRECT, STRATEGY_NAMES


def heldout_tables(experiment: Experiment) -> list[str]:
    """The held-out summary and figures of every configured face with test clips, and of its
    training-clips sweep, and the held-out dub (a face crop's through the product's own dub
    path, :mod:`miketalk_lab.evaluation.dub_crop`).

    Parameters
    ----------
    experiment : Experiment
        The workflow's experiment.

    Returns
    -------
    list of str
        Face by face.
    """
    out = []
    for face in experiment.configured:
        if not experiment.has_test(face):
            continue
        out += [
            paths.at(pattern, face)
            for pattern in (
                paths.HELDOUT_SUMMARY,
                paths.HELDOUT_TRAJECTORY_FIGURE,
                paths.HELDOUT_PSNR_FIGURE,
                paths.HELDOUT_STRIP_FIGURE,
            )
        ]
        out += [paths.at(pattern, face) for pattern in (paths.DUB_SUMMARY, paths.DUB_STRIP_FIGURE)]
        if experiment.sweep_of(face):
            out += [
                paths.at(paths.TRAINING_CLIPS_TABLE, face),
                paths.at(paths.TRAINING_CLIPS_FIGURE, face),
            ]
    return out


def epe_tables(experiment: Experiment) -> list[str]:
    """Per-method, per-strategy EPE tables of the truth face: each configured method in every
    strategy, each pyramid-depth sweep method direct (none without a truth face)."""
    if experiment.truth_face is None:
        return []
    tables = [
        paths.fill(paths.EPE, face=experiment.truth, method=m, strategy=s)
        for m in experiment.config["flow"]["methods"]
        for s in STRATEGY_NAMES
    ]
    tables += [
        paths.fill(paths.EPE, face=experiment.truth, method=m, strategy=DIRECT)
        for m in experiment.sweep_methods
    ]
    return tables


def utterance_videos(experiment: Experiment) -> list[str]:
    """The mp4 of every configured sentence, for every configured face."""
    return [
        paths.fill(paths.UTTERANCE_VIDEO, face=face, sentence=name)
        for face in experiment.configured
        for name in experiment.config["sentences"]
    ]


def sync_tables(experiment: Experiment) -> list[str]:
    """The sync table of every configured sentence (truth face)."""
    return [
        paths.fill(paths.SYNC, face=experiment.truth, sentence=name)
        for name in experiment.config["sentences"]
    ]


def sync_sweep_tables(experiment: Experiment) -> list[str]:
    """The sync table of every sync sweep point (truth face); at the configured point the sync
    rule's own table of the sweep sentence."""
    face = experiment.truth
    sentence = experiment.config["sweeps"]["sentence"]
    return [
        (
            paths.fill(paths.SYNC, face=face, sentence=sentence)
            if experiment.is_configured_point(face, sampling, px, fps)
            else paths.fill(paths.SYNC_SWEEP, face=face, sampling=sampling, px=px, fps=fps)
        )
        for sampling, px, fps in experiment.sync_sweep_points()
    ]


def sampling_strip_timelines(experiment: Experiment) -> list[str]:
    """The sweep sentence in each swept sampling mode at the strip's settings (figure face)."""
    px, fps = experiment.strip_max_px(), experiment.config["lipsync"]["fps"]
    return [
        experiment.sweep_timeline(experiment.figure_face, sampling, px, fps)
        for sampling in experiment.config["sweeps"]["sampling"]
    ]


def all_outputs(experiment: Experiment) -> list[str]:
    """The default target: every face's contact sheet, model and utterances, the held-out
    evaluations, the figures, and the measurements against truth (or the note that there is
    no truth face).

    Parameters
    ----------
    experiment : Experiment
        The workflow's experiment.

    Returns
    -------
    list of str
        The files of rule ``all``.
    """
    configured = experiment.configured
    out = [paths.at(paths.CONTACT_SHEET, face) for face in configured]
    out += [paths.at(paths.MODEL, face) for face in configured]
    out += utterance_videos(experiment)
    out += heldout_tables(experiment)
    out += [paths.LIPSYNC_DIAGRAM_FIGURE, paths.MORPH_STRIP_FIGURE, paths.SAMPLING_STRIP_FIGURE]
    if experiment.truth_face is not None:
        out += [
            paths.EPE_TABLE,
            paths.MORPH_FIDELITY_TABLE,
            paths.SYNC_TABLE,
            paths.SYNC_SWEEP_TABLE,
            paths.EPE_VS_LEVELS_FIGURE,
            paths.MORPH_PSNR_FIGURE,
            paths.SYNC_VS_MAX_PX_FIGURE,
            paths.SAMPLING_VS_MAX_PX_FIGURE,
        ]
    else:
        out.append(paths.TRUTH_SKIPPED)
    if experiment.config["metrics"]["motorcycle"]:
        out.append(paths.MOTORCYCLE_EPE)
    return out
