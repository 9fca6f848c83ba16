"""Every path pattern of the workflow, in one place: the rules, their input functions and the
targets take them from here.

A pattern is a string in Snakemake's wildcard syntax (``results/model/{face}``); the
per-face folders come from :mod:`miketalk.defaults` (where the CLI looks for them too),
the files inside them are named here. :func:`fill` and :func:`at` put values in, and
:func:`log` and :func:`benchmark` name a job's log and benchmark file. The wildcard
constraints the rules share are here too (:func:`one_of`, :data:`NUMBER`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from miketalk import defaults

#: Root of every workflow output.
RESULTS = str(defaults.RESULTS)
#: A job's log: ``results/logs/<rule>/<wildcards>.log`` (:func:`log`).
LOGS = f"{RESULTS}/logs"
#: A job's benchmark table: ``results/benchmarks/<rule>/<wildcards>.tsv`` (:func:`benchmark`).
BENCHMARKS = f"{RESULTS}/benchmarks"

# -- per-face folders: {face} is a wildcard --------------------------------------------------

#: A face's recording in the corpus folder format.
CORPUS = str(defaults.corpus_dir("{face}"))
#: A face's viseme images and their table.
VISEMES = str(defaults.visemes_dir("{face}"))
#: A face's flow databases, by method and strategy.
FLOWS = str(defaults.flows_dir("{face}"))
#: A face's model (what ``miketalk say`` reads).
MODEL = str(defaults.model_dir("{face}"))
#: The ground truth of the synthetic face (the truth face's).
TRUTH = str(defaults.truth_dir("{face}"))
#: A face's utterances: each configured sentence, and the sync sweep's.
UTTERANCES = f"{RESULTS}/utterances/{{face}}"
#: A one-video face's utterances, found in its video (:mod:`miketalk.corpus.one_video`).
SEGMENTS = f"{RESULTS}/segments/{{face}}.json"
#: The models a held-out evaluation measures besides the face's own, as ``<method>/<strategy>``.
VARIANTS = f"{RESULTS}/model_variants/{{face}}"
#: Tidy tables.
METRICS = str(defaults.metrics_dir())
#: Figures.
FIGURES = str(defaults.figures_dir())

# -- the corpus ----------------------------------------------------------------------------

CORPUS_FRAMES = f"{CORPUS}/frames"
CORPUS_AUDIO = f"{CORPUS}/audio.wav"
CORPUS_WORDS = f"{CORPUS}/words.json"
CORPUS_TABLE = f"{CORPUS}/frames.tsv"
CORPUS_TRUTH = f"{CORPUS}/truth.tsv"
CORPUS_VIDEO = f"{CORPUS}/corpus.mp4"
# a face from clips (or one video) also has
CORPUS_CLIPS = f"{CORPUS}/clips.tsv"
CORPUS_PHONES = f"{CORPUS}/phones.tsv"
CORPUS_STABILIZATION = f"{CORPUS}/stabilization.tsv"
CORPUS_SKIPPED = f"{CORPUS}/skipped.tsv"
CORPUS_REGIONS = f"{CORPUS}/regions.json"
CORPUS_REFERENCE = f"{CORPUS}/reference.png"
CORPUS_REGISTRATION_MASK = f"{CORPUS}/registration_mask.png"
CORPUS_FACE_MASK = f"{CORPUS}/face_mask.png"
CORPUS_MOUTH_MASK = f"{CORPUS}/mouth_mask.png"
#: The eigenlip coordinates of a clips face's aligned frames.
EIGENLIPS = f"{CORPUS}/eigenlips.npz"

# -- visemes -------------------------------------------------------------------------------

VISEME_TARGETS = f"{VISEMES}/targets.tsv"
#: A clips face's candidate frame per phone (instead of the corpus words' targets).
VISEME_CANDIDATES = f"{VISEMES}/candidates.tsv"
VISEME_TABLE = f"{VISEMES}/visemes.tsv"
VISEME_IMAGES = f"{VISEMES}/images"
CONTACT_SHEET = f"{VISEMES}/contact_sheet.png"
WORD_STRIP = f"{VISEMES}/word_strip.png"

# -- flows, models and truth ---------------------------------------------------------------

#: A flow database: {method} a key of flow.methods (or a sweep method), {strategy} a strategy.
FLOW_DATABASE = f"{FLOWS}/{{method}}/{{strategy}}"
#: The strategy's choice for each pair of the database.
FLOW_CHOICES = f"{FLOW_DATABASE}.tsv"
#: A model variant of a held-out evaluation.
VARIANT = f"{VARIANTS}/{{method}}/{{strategy}}"
TRUE_FLOWS = f"{TRUTH}/flows"
TRUE_MOUTH = f"{TRUTH}/mouth_mask.png"

# -- utterances ----------------------------------------------------------------------------

UTTERANCE_VIDEO = f"{UTTERANCES}/{{sentence}}.mp4"
UTTERANCE_TIMELINE = f"{UTTERANCES}/{{sentence}}.json"
#: The sync sweep's sentence at one point: sampling mode, max_px_per_frame and fps.
SWEEP_POINT = "{sampling}/px{px}_fps{fps}"
SWEEP_VIDEO = f"{UTTERANCES}/sweep/{SWEEP_POINT}.mp4"
SWEEP_TIMELINE = f"{UTTERANCES}/sweep/{SWEEP_POINT}.json"

# -- metrics -------------------------------------------------------------------------------

#: Endpoint error of one flow database of the truth face.
EPE = f"{METRICS}/epe/{{face}}/{{method}}/{{strategy}}.csv"
EPE_TABLE = f"{METRICS}/flow_epe.csv"
EPE_SUMMARY = f"{METRICS}/flow_epe_summary.csv"
MOTORCYCLE_EPE = f"{METRICS}/motorcycle_epe.csv"
MORPH_FIDELITY_TABLE = f"{METRICS}/morph_fidelity.csv"
MORPH_FIDELITY_SUMMARY = f"{METRICS}/morph_fidelity_summary.csv"
#: Sync of one sentence of the truth face.
SYNC = f"{METRICS}/sync/{{face}}/{{sentence}}.csv"
SYNC_SWEEP = f"{METRICS}/sync_sweep/{{face}}/{SWEEP_POINT}.csv"
SYNC_TABLE = f"{METRICS}/sync.csv"
SYNC_SUMMARY = f"{METRICS}/sync_summary.csv"
SYNC_SWEEP_TABLE = f"{METRICS}/sync_sweep.csv"
SYNC_SWEEP_SUMMARY = f"{METRICS}/sync_sweep_summary.csv"
#: Written instead of the measurements against truth when there is no synthetic face.
TRUTH_SKIPPED = f"{METRICS}/SKIPPED.txt"
HELDOUT_FRAMES = f"{METRICS}/heldout/{{face}}/frames.csv"
HELDOUT_CLIPS = f"{METRICS}/heldout/{{face}}/clips.csv"
HELDOUT_SUMMARY = f"{METRICS}/heldout/{{face}}/summary.csv"
#: The held-out summaries of a face's training-clips sweep, side by side.
TRAINING_CLIPS_TABLE = f"{METRICS}/heldout/{{face}}/training_clips.csv"
DUB_CLIPS = f"{METRICS}/dub/{{face}}/clips.csv"
DUB_SUMMARY = f"{METRICS}/dub/{{face}}/summary.csv"
#: The videos of the held-out re-synthesis and of the dubs.
HELDOUT_VIDEOS = f"{RESULTS}/heldout/{{face}}"
DUB_VIDEOS = f"{RESULTS}/dub/{{face}}"

# -- figures -------------------------------------------------------------------------------

EPE_VS_LEVELS_FIGURE = f"{FIGURES}/epe_vs_levels.png"
MORPH_PSNR_FIGURE = f"{FIGURES}/morph_psnr_vs_alpha.png"
SYNC_VS_MAX_PX_FIGURE = f"{FIGURES}/sync_vs_max_px.png"
SAMPLING_VS_MAX_PX_FIGURE = f"{FIGURES}/sampling_vs_max_px.png"
LIPSYNC_DIAGRAM_FIGURE = f"{FIGURES}/lipsync_diagram.png"
MORPH_STRIP_FIGURE = f"{FIGURES}/morph_strip.png"
SAMPLING_STRIP_FIGURE = f"{FIGURES}/sampling_strip.png"
HELDOUT_TRAJECTORY_FIGURE = f"{FIGURES}/heldout/{{face}}/trajectory.png"
HELDOUT_PSNR_FIGURE = f"{FIGURES}/heldout/{{face}}/psnr.png"
HELDOUT_STRIP_FIGURE = f"{FIGURES}/heldout/{{face}}/strip.png"
TRAINING_CLIPS_FIGURE = f"{FIGURES}/heldout/{{face}}/training_clips.png"
DUB_STRIP_FIGURE = f"{FIGURES}/dub/{{face}}/strip.png"

# -- wildcard constraints ------------------------------------------------------------------

#: A sweep setting in a path (px{px}_fps{fps}): a plain decimal number.
NUMBER = r"\d+(\.\d+)?"


def one_of(names: Iterable[str]) -> str:
    """A wildcard constraint matching exactly ``names`` (nothing when there are none).

    Parameters
    ----------
    names : iterable of str
        The names the wildcard may take.

    Returns
    -------
    str
        The names, escaped, joined by ``|``; ``(?!)`` (never matches) for none.
    """
    return "|".join(re.escape(n) for n in names) or "(?!)"


# -- filling in ----------------------------------------------------------------------------


def fill(pattern: str, **wildcards: object) -> str:
    """``pattern`` with the named wildcards filled in (the others left as they are).

    Parameters
    ----------
    pattern : str
        A path pattern, e.g. :data:`SYNC`.
    **wildcards
        Values by wildcard name, written as an f-string writes them.

    Returns
    -------
    str
        E.g. ``fill(SYNC, face="synthetic")`` is
        ``results/metrics/sync/synthetic/{sentence}.csv``.
    """
    for name, value in wildcards.items():
        pattern = pattern.replace(f"{{{name}}}", f"{value}")
    return pattern


def at(pattern: str, face: str) -> str:
    """``pattern`` with the {face} wildcard filled in (:func:`fill`)."""
    return fill(pattern, face=face)


def log(name: str, **wildcards: object) -> str:
    """The log of a job: ``results/logs/<name>.log``.

    Parameters
    ----------
    name : str
        The rule's name and the job's wildcards, e.g. ``"corpus/{face}"``.
    **wildcards
        Wildcards to fill in (:func:`fill`), e.g. the truth face's name.

    Returns
    -------
    str
        A pattern, or a path when every wildcard is filled.
    """
    return fill(f"{LOGS}/{name}.log", **wildcards)


def benchmark(name: str, **wildcards: object) -> str:
    """The benchmark table of a job: ``results/benchmarks/<name>.tsv`` (as :func:`log`)."""
    return fill(f"{BENCHMARKS}/{name}.tsv", **wildcards)
