"""The rules' functions of wildcards: their input functions, and the params and priority
they compute per job.

Snakemake calls each with the job's ``wildcards`` (anything with the attributes ``face``,
``method``, ``strategy``, ...: a test passes a :class:`types.SimpleNamespace`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from miketalk.flow.strategies import STRATEGIES
from miketalk_lab.workflow import paths
from miketalk_lab.workflow.checks import clip_path
from miketalk_lab.workflow.experiment import Experiment

#: Priority of the jobs of a face from clips. Its chain (corpus, visemes, flows, model,
#: eigenlips, held-out test) is the longest in the workflow and mostly one job at a time;
#: started first, it runs beside the synthetic face's many short jobs instead of alone
#: after them.
CLIP_CHAIN = 10

#: A job's wildcards, as Snakemake passes them.
Wildcards = Any


class Inputs:
    """The functions of wildcards of the rules of ``experiment``.

    Parameters
    ----------
    experiment : Experiment
        The workflow's experiment.
    """

    #: :data:`CLIP_CHAIN`, for the rules that only run for faces from clips.
    CLIP_CHAIN = CLIP_CHAIN

    def __init__(self, experiment: Experiment) -> None:
        self.experiment = experiment

    def clip_inputs(self, split: str) -> Callable[[Wildcards], dict]:
        """Input function: the transcript table, media and word timings of a face's clips of
        ``split`` (train or test), so a changed or missing one is seen before any job; for
        a one-video face its video and its utterances.

        Parameters
        ----------
        split : str
            ``"train"`` or ``"test"``.

        Returns
        -------
        callable
            Wildcards -> named inputs (to unpack).
        """

        def inputs(wildcards: Wildcards) -> dict:
            face = wildcards.face
            corpus = self.experiment.corpus_settings(face)
            if self.experiment.one_video(face):
                return {"media": corpus["media"], "segments": paths.at(paths.SEGMENTS, face)}
            files = {
                "transcripts": corpus["transcripts"],
                "media": [clip_path(corpus["media"], clip) for clip in corpus[split]],
            }
            if corpus["timings"]:
                files["timings"] = [clip_path(corpus["timings"], clip) for clip in corpus[split]]
            return files

        return inputs

    def video_script(self, wildcards: Wildcards) -> dict:
        """A one-video face's video and its transcript or subtitles."""
        corpus = self.experiment.corpus_settings(wildcards.face)
        return {key: corpus[key] for key in ("media", "transcript", "subtitles") if corpus[key]}

    def method_spec(self, wildcards: Wildcards) -> str:
        """Params: the {method} wildcard's estimator and settings, as JSON."""
        return self.experiment.method_json(wildcards.method)

    def mixed_flows(self, wildcards: Wildcards) -> dict:
        """A strategy that refines another (bridge: mixed) reads that database of the same
        method."""
        refines = STRATEGIES[wildcards.strategy].refines
        if refines is None:
            return {}
        mixed = paths.fill(
            paths.FLOW_DATABASE, face=wildcards.face, method=wildcards.method, strategy=refines
        )
        return {"mixed": mixed}

    def clip_regions(self, wildcards: Wildcards) -> dict:
        """A clips face's flows are estimated around the mouth (the corpus's regions.json)."""
        if wildcards.face not in self.experiment.clip_faces:
            return {}
        return {"regions": paths.at(paths.CORPUS_REGIONS, wildcards.face)}

    def clip_corpus(self, wildcards: Wildcards) -> dict:
        """A face from clips also learns its coarticulation from its corpus's aligned frames
        (their eigenlip coordinates)."""
        face = wildcards.face
        if face not in self.experiment.clip_faces:
            return {}
        files = {
            "phones": paths.at(paths.CORPUS_PHONES, face),
            "regions": paths.at(paths.CORPUS_REGIONS, face),
            "eigenlips": paths.at(paths.EIGENLIPS, face),
        }
        if self.experiment.one_video(face):  # where its reference utterance is in the video
            files["segments"] = paths.at(paths.SEGMENTS, face)
        return files

    def crop_dub_inputs(self, wildcards: Wildcards) -> dict:
        """A face crop's held-out dub reads its test clips back registered to the corpus's
        reference (:func:`~miketalk.corpus.clips.corpus_stabilizer`); a face in its video's
        own pixels registers to its model's, and its rule's inputs stay as they were."""
        if self.experiment.frame_settings(wildcards.face).crop is None:
            return {}
        return {"reference": paths.at(paths.CORPUS_REFERENCE, wildcards.face)}

    def clip_chain_first(self, wildcards: Wildcards) -> int:
        """A job's priority: :data:`CLIP_CHAIN` for a face from clips, else 0."""
        return CLIP_CHAIN if wildcards.face in self.experiment.clip_faces else 0

    def model_flows(self, wildcards: Wildcards) -> str:
        """The flow database of a face's model."""
        return self.experiment.model_flows(wildcards.face)

    def heldout_models(self, wildcards: Wildcards) -> dict:
        """The models a held-out evaluation measures: the face's own and evaluation.models
        (a face of the training-clips sweep: its own only)."""
        face = wildcards.face
        own = "/".join(self.experiment.model_flow(face))
        models = {f"model:{own}": paths.at(paths.MODEL, face)}
        if face not in self.experiment.configured:
            return models
        for name in self.experiment.config["evaluation"]["models"]:
            if name != own:
                models[f"model:{name}"] = f"{paths.at(paths.VARIANTS, face)}/{name}"
        return models

    def training_clip_summaries(self, wildcards: Wildcards) -> list[str]:
        """The held-out summaries of a face's training-clips sweep."""
        return [
            paths.at(paths.HELDOUT_SUMMARY, f)
            for f in self.experiment.sweep_of(wildcards.face).values()
        ]
