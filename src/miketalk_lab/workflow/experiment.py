"""The experiment a config describes: its faces by kind, each face's settings, its flow
methods and sweeps, checked before any job.

:meth:`Experiment.from_config` is what the workflow's ``common.smk`` builds from
Snakemake's ``config`` and the project directory; nothing here reads Snakemake's globals,
so a test builds one from a config dict alone.
"""

from __future__ import annotations

import json
from pathlib import Path

from miketalk.building.frame import FrameSettings, own_frame
from miketalk.composite.for_model import BACKGROUND_CHOICES
from miketalk_lab.workflow import checks, faces, paths, sweeps
from miketalk_lab.workflow.config import SCHEMA, canonical, project_path, validate_config
from miketalk_lab.workflow.vocabulary import PAPER

#: What a face's utterances may play under the mouth besides a video of the person (the
#: schema's ``faces.NAME.background``): the library's.
BACKGROUNDS = BACKGROUND_CHOICES


class Experiment:
    """A validated config and what it derives.

    Parameters
    ----------
    config : dict
        The config, validated (its defaults filled in: :meth:`from_config`).
    root : str or Path
        The project directory: relative paths in the config are relative to it.

    Attributes
    ----------
    config : dict
        The config.
    root : Path
        The project directory.
    faces : dict
        Every face's settings by name: the configured faces, then the training-clips
        sweep's (:func:`~miketalk_lab.workflow.sweeps.training_sweep_faces`).
    corpus_word_faces : list of str
        Faces recorded speaking the paper's corpus words (synthetic, or a person's video).
    video_faces : list of str
        Faces from one video of any speech, cut into utterances (segments.json).
    clip_faces : list of str
        Faces built from clips of ordinary speech (the utterances of one video too).
    truth_face : str or None
        The face every measurement against ground truth uses: the first synthetic one.
    truth : str
        The name the truth face's paths are filled with (``"none"`` without one: no job
        then asks for them).
    figure_face : str
        The face of the figures drawn from a model: the truth face, else the first.
    sweep_methods : dict
        The flow methods of the pyramid-depth sweep (:func:`~.sweeps.sweep_methods`).
    methods : dict
        Every flow method by name: ``flow.methods``, then the pyramid-depth sweep's.
    """

    def __init__(self, config: dict, root: str | Path) -> None:
        self.config = config
        self.root = Path(root)
        configured = config["faces"]
        counts = config["sweeps"]["training_clips"]
        self.faces: dict[str, dict] = {
            **configured,
            **sweeps.training_sweep_faces(configured, counts, self.root),
        }
        self.corpus_word_faces = [f for f, s in self.faces.items() if faces.speaks_corpus_words(s)]
        self.video_faces = [f for f, s in self.faces.items() if faces.is_one_video(s)]
        self.clip_faces = [f for f, s in self.faces.items() if faces.is_from_clips(s)]
        self.truth_face = faces.truth_face(self.faces)
        self.truth = self.truth_face or "none"
        self.figure_face = faces.figure_face(self.faces)
        methods = config["flow"]["methods"]
        self.sweep_methods = sweeps.sweep_methods(config["sweeps"], methods)
        self.methods: dict[str, dict] = {**methods, **self.sweep_methods}

    @classmethod
    def from_config(cls, config: dict, root: str | Path) -> Experiment:
        """Validate ``config`` (filling in its defaults in place), derive, check every face.

        Parameters
        ----------
        config : dict
            The config as loaded (Snakemake's ``config``).
        root : str or Path
            The project directory, where the schema (:data:`~.config.SCHEMA`) is.

        Returns
        -------
        Experiment

        Raises
        ------
        ConfigError
            For a schema violation, settings that do not go together, or a face's missing
            files: one line each (the first few of a face's files).
        MiketalkError
            For an unknown flow strategy.
        """
        validate_config(config, Path(root) / SCHEMA)
        experiment = cls(config, root)
        experiment.check_settings()
        experiment.check_files()
        return experiment

    # -- checks ----------------------------------------------------------------------------

    def check_settings(self) -> None:
        """Check each face's settings go together (:func:`~.checks.check_face_settings`).

        Raises
        ------
        ConfigError
            For the first face whose settings do not.
        """
        checks.check_flow_methods(self.methods)
        for face in self.faces:
            method, strategy = self.model_flow(face)
            checks.check_frame(face, self.faces[face], from_clips=face in self.clip_faces)
            checks.check_face_settings(
                face,
                lipsync=self.lipsync_options(face),
                recording_model=self.recording_model(face),
                from_clips=face in self.clip_faces,
                method=method,
                strategy=strategy,
                methods=self.config["flow"]["methods"],
            )

    def check_files(self, shown: int = 5) -> None:
        """Refuse a configured face whose clips (or video) are not all there.

        Parameters
        ----------
        shown : int
            How many of a face's problems are said.

        Raises
        ------
        ConfigError
            For the first such face: its first ``shown`` problems, one per line.
        """
        for face, settings in self.configured.items():
            if faces.is_one_video(settings):
                problems = checks.video_problems(face, self.corpus_settings(face))
            elif faces.source(settings) == faces.CLIPS:
                problems = checks.clip_problems(face, self.corpus_settings(face))
            else:
                problems = []
            checks.refuse(problems, shown)

    # -- faces -----------------------------------------------------------------------------

    @property
    def configured(self) -> dict[str, dict]:
        """The configured faces' settings (without the training-clips sweep's)."""
        return self.config["faces"]

    def one_video(self, face: str) -> bool:
        """Whether a face's corpus is one video of any speech."""
        return faces.is_one_video(self.faces[face])

    def has_test(self, face: str) -> bool:
        """Whether a face from clips (or one video) has held-out clips to measure."""
        return faces.has_test(self.faces[face])

    def first_test_clip(self, face: str) -> str | None:
        """The clip of a face's held-out figures (None: the first one measured)."""
        return faces.first_test_clip(self.faces[face])

    @property
    def truth_size(self) -> int | None:
        """The frame size of the truth face's recording (None without one)."""
        return self.faces[self.truth_face]["corpus"]["size"] if self.truth_face else None

    # -- each face's settings --------------------------------------------------------------

    def project_path(self, path: str | Path | None) -> str | None:
        """A path from the config, absolute (relative ones are in the project directory)."""
        return project_path(path, self.root)

    def corpus_settings(self, face: str) -> dict:
        """A face's corpus settings with its paths made absolute (clips: patterns keep {id})."""
        corpus = dict(self.faces[face]["corpus"])
        for key in ("video", "media", "transcripts", "timings", "transcript", "subtitles"):
            corpus[key] = self.project_path(corpus.get(key))
        return canonical(corpus)

    def frame_settings(self, face: str) -> FrameSettings:
        """The frame a face is built in: its ``frame`` (null: the face's own,
        :func:`miketalk.building.frame.own_frame`: the crop for a face from clips or one
        video, as ``miketalk build``'s) and ``crop_size``."""
        settings = self.faces[face]
        frame = own_frame(settings["frame"], of_person=face in self.clip_faces)
        return FrameSettings(frame, settings["crop_size"])

    def corpus_build_settings(self, face: str) -> dict:
        """A face's corpus settings as its corpus rule takes them (:meth:`corpus_settings`),
        with, for a face built in its face crop, the crop under ``crop``
        (:func:`~miketalk.track.crop.crop_doc`); a face in its video's own pixels has no
        ``crop`` key, so its rule's params are what they were before the key existed."""
        from miketalk.track.crop import crop_doc

        corpus, crop = self.corpus_settings(face), self.frame_settings(face).crop
        return corpus if crop is None else canonical(corpus | {"crop": crop_doc(crop)})

    def morph_options(self, face: str) -> dict:
        """The morph settings of a face: ``morph``, with the face's own overrides."""
        own = self.faces[face].get("morph", {}) if face in self.faces else {}
        return canonical({**self.config["morph"], **own})

    def _configured_lipsync(self, face: str) -> dict:
        own = self.faces[face].get("lipsync", {}) if face in self.faces else {}
        return {**self.config["lipsync"], **own}

    def own_lipsync_model(self, face: str, *, recorded: bool) -> str:
        """The face's own lip-sync model, where the config names none: the library's choice
        (:func:`miketalk.lipsync.settings.resolve_lipsync_model`) among the models the face's
        model will have (the fitted ones only for a face from clips)."""
        from miketalk.lipsync.settings import LIPSYNC_MODELS, resolve_lipsync_model

        available = LIPSYNC_MODELS if face in self.clip_faces else (PAPER,)
        return resolve_lipsync_model(None, available=available, recorded=recorded).value

    def lipsync_options(self, face: str) -> dict:
        """The lip-sync settings of a face: ``lipsync``, with the face's own overrides; a
        ``model`` of null is the face's own for typed text (:meth:`own_lipsync_model`)."""
        options = self._configured_lipsync(face)
        if options["model"] is None:
            options["model"] = self.own_lipsync_model(face, recorded=False)
        return canonical(options)

    def recording_model(self, face: str) -> str:
        """The lip-sync model of a face's utterances driven by a recording (the held-out
        dubs): its recording_model, else its configured model, else the face's own for a
        recording."""
        options = self._configured_lipsync(face)
        if options["recording_model"] is not None:
            return options["recording_model"]
        if options["model"] is not None:
            return options["model"]
        return self.own_lipsync_model(face, recorded=True)

    def face_background(self, face: str) -> str | None:
        """What a face's utterances play under the mouth: auto, still or a video (absolute)."""
        choice = self.faces[face].get("background", "auto") if face in self.faces else "still"
        return choice if choice in BACKGROUNDS else self.project_path(choice)

    def model_flow(self, face: str) -> tuple[str, str]:
        """The flow method and strategy of a face's model (the configured ones for no face)."""
        own = self.faces[face].get("flow", {}) if face in self.faces else {}
        flow = self.config["flow"]
        return own.get("method", flow["method"]), own.get("strategy", flow["strategy"])

    def model_flows(self, face: str) -> str:
        """The flow database of a face's model."""
        method, strategy = self.model_flow(face)
        return paths.fill(paths.FLOW_DATABASE, face=face, method=method, strategy=strategy)

    def method_json(self, name: str) -> str:
        """The estimator name and settings of flow method ``name``, as JSON (keys sorted)."""
        spec = self.methods[name]
        return json.dumps(
            {"estimator": spec["estimator"], "settings": spec.get("settings", {})},
            sort_keys=True,
        )

    @property
    def grouping(self) -> dict:
        """``visemes.grouping``, canonical: a param."""
        return canonical(self.config["visemes"]["grouping"])

    # -- sweeps ----------------------------------------------------------------------------

    def sweep_of(self, face: str) -> dict[int, str]:
        """A face's training-clips sweep, {number of clips: face}, the face itself last."""
        return sweeps.sweep_of(face, self.faces, self.config["sweeps"]["training_clips"])

    def sync_sweep_points(self) -> list[sweeps.Point]:
        """(sampling, px, fps) of the sync sweep, sorted (:func:`~.sweeps.sync_sweep_points`)."""
        return sweeps.sync_sweep_points(self.config["sweeps"], self.config["lipsync"])

    def is_configured_point(self, face: str, sampling: str, px: float, fps: float) -> bool:
        """Whether a sweep point is the face's own configured utterance settings, with the
        paper's model (:func:`~.sweeps.is_configured_point`)."""
        return sweeps.is_configured_point(self.lipsync_options(face), sampling, px, fps)

    def sweep_lipsync(self, face: str, sampling: str) -> dict:
        """The lip-sync settings of a face's sweep utterance in ``sampling``."""
        return sweeps.sweep_lipsync(self.lipsync_options(face), sampling)

    def sweep_timeline(self, face: str, sampling: str, px: float, fps: float) -> str:
        """The timeline of the sweep sentence said by ``face`` at one sweep point: at the
        configured point the utterance rule's own, elsewhere the sweep utterance's."""
        if self.is_configured_point(face, sampling, px, fps):
            sentence = self.config["sweeps"]["sentence"]
            return paths.fill(paths.UTTERANCE_TIMELINE, face=face, sentence=sentence)
        return paths.fill(paths.SWEEP_TIMELINE, face=face, sampling=sampling, px=px, fps=fps)

    def strip_max_px(self) -> float:
        """The max_px_per_frame of the sampling strip: lipsync's, or the default for none."""
        return sweeps.strip_max_px(self.config["lipsync"])
