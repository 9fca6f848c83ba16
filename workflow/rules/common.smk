# Names, paths and lookups shared by the rules.
import json
import re
from types import SimpleNamespace
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

from miketalk import defaults
from miketalk.flow.strategies import STRATEGIES, get_strategy
from miketalk.lipsync.settings import SAMPLINGS

ROOT = Path(workflow.basedir)


def validate_config():
    """Check the config against the schema, filling in its defaults, before anything reads it.

    A violation is one line naming the key, e.g. ``config: faces.s1.corpus.train:
    [] should be non-empty``, instead of the schema's dump.
    """
    try:
        validate(config, "../schemas/config.schema.yaml")
    except WorkflowError as err:
        cause = err.__context__  # the jsonschema ValidationError
        if not hasattr(cause, "absolute_path"):
            raise
        key = ".".join(str(part) for part in cause.absolute_path) or "the config"
        message = cause.message
        if cause.validator == "oneOf" and key.endswith(
            ".corpus"
        ):  # source video's choices
            message = (
                "source video takes video (a recording of the corpus words), or media with "
                "its transcript or its subtitles (one of the two)"
            )
        if cause.validator == "uniqueItems":  # name the repeated items
            items = [str(item) for item in cause.instance]
            message = f"{', '.join(sorted({i for i in items if items.count(i) > 1}))} listed twice"
        raise WorkflowError(f"config: {key}: {message}") from None


validate_config()


def training_sweep_faces():
    """For each face from clips: the same face from N training clips, for each N in the sweep.

    Named '<face>-n<N>'; they share the face's test clips. N smaller than the
    face's own number of training clips: its first N. N larger: all of them,
    then the other clips of its transcript table that are not test clips, in
    name order (:func:`sweep_training_clips`).
    """
    out = {}
    for face, settings in config["faces"].items():
        corpus = settings["corpus"]
        if corpus["source"] != "clips" or not corpus["test"]:
            continue
        for n in config["sweeps"]["training_clips"]:
            if n != len(corpus["train"]):
                train = sweep_training_clips(face, corpus, n)
                out[f"{face}-n{n}"] = {**settings, "corpus": {**corpus, "train": train}}
    return out


def sweep_training_clips(face, corpus, n):
    """The first ``n`` of the face's training clips, then of the transcript table's other
    clips that are not test clips (in name order): never a test clip."""
    from miketalk.corpus.clip_sources import read_transcripts

    train = list(corpus["train"])
    if n <= len(train):
        return train[:n]
    taken = set(train) | set(corpus["test"])
    transcripts = Path(corpus["transcripts"])  # project_path, defined below
    transcripts = transcripts if transcripts.is_absolute() else ROOT / transcripts
    others = sorted(set(read_transcripts(transcripts)) - taken)
    if len(train) + len(others) < n:
        raise ValueError(
            f"sweeps.training_clips: {n} clips for faces.{face}, but its transcript table has "
            f"only {len(train) + len(others)} clips that are not test clips"
        )
    return train + others[: n - len(train)]


#: The configured faces, and the faces of the training-clips sweep.
FACES = {**config["faces"], **training_sweep_faces()}


def source_of(face):
    return FACES[face]["corpus"]["source"]


def one_video(face):
    """Whether a face's corpus is one video of any speech (source video with media)."""
    return source_of(face) == "video" and bool(FACES[face]["corpus"].get("media"))


#: Faces recorded speaking the paper's corpus words (synthetic, or a person's video of them).
CORPUS_WORD_FACES = [
    f for f in FACES if source_of(f) in ("synthetic", "video") and not one_video(f)
]
#: Faces from one video of any speech, cut into utterances (segments.json).
VIDEO_FACES = [f for f in FACES if one_video(f)]
#: Faces built from clips of ordinary speech (the utterances of one video too).
CLIP_FACES = [f for f in FACES if source_of(f) == "clips" or one_video(f)]


def has_test(face):
    """Whether a face from clips (or one video) has held-out clips to measure."""
    corpus = FACES[face]["corpus"]
    if one_video(face):
        return corpus["heldout_seconds"] > 0
    return corpus["source"] == "clips" and bool(corpus["test"])


#: The face every measurement against ground truth uses: the first synthetic one.
TRUTH_FACE = next((f for f in FACES if source_of(f) == "synthetic"), None)
#: The face of the figures drawn from a model (the lip-sync diagram, the morph strip).
FIGURE_FACE = TRUTH_FACE or next(iter(FACES))

# per-face paths: {face} is a wildcard
CORPUS = str(defaults.corpus_dir("{face}"))
VISEMES = str(defaults.visemes_dir("{face}"))
FLOWS = str(defaults.flows_dir("{face}"))
MODEL = str(defaults.model_dir("{face}"))
UTTERANCES = str(defaults.RESULTS / "utterances" / "{face}")
#: A one-video face's utterances (miketalk.corpus.one_video)
SEGMENTS = str(defaults.RESULTS / "segments" / "{face}.json")
VARIANTS = str(defaults.RESULTS / "model_variants" / "{face}")
METRICS = str(defaults.metrics_dir())
FIGURES = str(defaults.figures_dir())
# the truth face's paths
TRUTH = str(defaults.truth_dir(TRUTH_FACE or "none"))


def at(path, face):
    """``path`` with the {face} wildcard filled in."""
    return path.replace("{face}", face)


def one_of(names):
    """A wildcard constraint matching exactly these names (nothing when there are none)."""
    return "|".join(re.escape(n) for n in names) or "(?!)"


def project_path(path):
    """A path from the config: relative ones are relative to the project directory."""
    if path is None:
        return None
    return str(path) if Path(path).is_absolute() else str(ROOT / path)


def canonical(value):
    """``value`` with the keys of every mapping in it sorted (lists keep their order).

    Params are compared as written (their repr), and the schema's defaults are
    added after the keys a config gives: a config with the same settings in
    another key order would otherwise change every dict param and rerun the
    workflow. Every dict param goes through here.
    """
    if isinstance(value, dict):
        return {key: canonical(value[key]) for key in sorted(value)}
    if isinstance(value, list):
        return [canonical(item) for item in value]
    return value


def corpus_settings(face):
    """A face's corpus settings with its paths made absolute (clips: patterns keep {id})."""
    corpus = dict(FACES[face]["corpus"])
    for key in ("video", "media", "transcripts", "timings", "transcript", "subtitles"):
        corpus[key] = project_path(corpus.get(key))
    return canonical(corpus)


def morph_options(face):
    """The morph settings of a face: morph, with the face's own overrides."""
    own = FACES[face].get("morph", {}) if face in FACES else {}
    return canonical({**config["morph"], **own})


def lipsync_options(face):
    """The lip-sync settings of a face: lipsync, with the face's own overrides."""
    own = FACES[face].get("lipsync", {}) if face in FACES else {}
    return canonical({**config["lipsync"], **own})


def recording_model(face):
    """The lip-sync model of a face's utterances driven by a recording (the held-out dubs):
    its recording_model, else its model."""
    options = lipsync_options(face)
    return options["recording_model"] or options["model"]


def face_background(face):
    """What a face's utterances play under the mouth: auto, still or a video (absolute)."""
    choice = FACES[face].get("background", "auto") if face in FACES else "still"
    return choice if choice in ("auto", "still") else project_path(choice)


def model_flow(face):
    """The flow method and strategy of a face's model (the configured ones for no face)."""
    own = FACES[face].get("flow", {}) if face in FACES else {}
    return (
        own.get("method", config["flow"]["method"]),
        own.get("strategy", config["flow"]["strategy"]),
    )


# an unknown method or strategy fails here, naming the known ones
for _face in FACES:
    _method, _strategy = model_flow(_face)
    get_strategy(_strategy)
    for _key, _model in (
        ("model", lipsync_options(_face)["model"]),
        ("recording_model", recording_model(_face)),
    ):
        if _model in ("learned", "trained") and _face not in CLIP_FACES:
            raise ValueError(
                f"faces.{_face}: lipsync {_key} {_model!r} needs a face built from clips "
                "(it is fitted to their aligned frames)"
            )
    if (
        lipsync_options(_face)["trajectory"] is not None
        and lipsync_options(_face)["model"] != "trained"
    ):
        raise ValueError(
            f"faces.{_face}: lipsync trajectory goes with lipsync model trained, not "
            f"{lipsync_options(_face)['model']!r}"
        )
    if _method not in config["flow"]["methods"]:
        raise ValueError(
            f"faces.{_face}: flow method {_method!r} is not in flow.methods "
            f"({', '.join(config['flow']['methods'])})"
        )


def clip_path(pattern, clip):
    """A clip's file: ``pattern`` with its {id} filled in."""
    return pattern.replace("{id}", clip)


def clip_problems(face):
    """What is wrong with a face's clips, one line each naming the face and the clip."""
    from miketalk.corpus.clip_sources import read_transcripts
    from miketalk.errors import MiketalkError

    where = f"faces.{face}.corpus"
    corpus = corpus_settings(face)
    for key in ("media", "transcripts"):
        if not corpus[key]:
            return [f"{where}: a face from clips needs {key}"]
    for key in ("media", "timings"):
        if corpus[key] and "{id}" not in corpus[key]:
            return [f"{where}.{key} must contain {{id}}, got {corpus[key]!r}"]
    held_out = set(corpus["test"])
    problems = [
        f"{where}: clip {clip} is in both train and test (a held-out clip must never "
        "be read while building the model)"
        for clip in corpus["train"]
        if clip in held_out
    ]
    try:
        table = read_transcripts(corpus["transcripts"])
    except MiketalkError as err:
        return [*problems, f"{where}: {err}"]
    for split in ("train", "test"):
        for clip in corpus[split]:
            if clip not in table:  # a mistyped id: its files are missing too, unsaid
                problems.append(
                    f"{where}: clip {clip} ({split}) is not in the transcript table "
                    f"{corpus['transcripts']}"
                )
                continue
            if not Path(media := clip_path(corpus["media"], clip)).is_file():
                problems.append(
                    f"{where}: clip {clip} ({split}): media file not found: {media}"
                )
            timings = corpus["timings"] and clip_path(corpus["timings"], clip)
            if timings and not Path(timings).is_file():
                problems.append(
                    f"{where}: clip {clip} ({split}): word timing file not found: {timings}"
                )
    return problems


def video_problems(face):
    """What is wrong with a one-video face's files, one line each naming the face."""
    where = f"faces.{face}.corpus"
    corpus = corpus_settings(face)
    problems = []
    for key in ("media", "transcript", "subtitles"):
        if corpus[key] and not Path(corpus[key]).is_file():
            problems.append(f"{where}.{key}: file not found: {corpus[key]}")
    if corpus["subtitles"] and Path(corpus["subtitles"]).suffix.lower() not in (
        ".srt",
        ".vtt",
    ):
        problems.append(
            f"{where}.subtitles must be .srt or .vtt: {corpus['subtitles']}"
        )
    for key in ("train", "test", "timings", "transcripts"):
        if corpus[key]:
            problems.append(
                f"{where}.{key}: not for a face from one video (its utterances are found "
                "in it; heldout_seconds holds out its end)"
            )
    return problems


def check_clip_faces(shown=5):
    """Refuse, before any job, a face whose clips are not all there (the first few problems)."""
    for face, settings in config["faces"].items():
        if one_video(face):
            problems = video_problems(face)
        elif settings["corpus"]["source"] == "clips":
            problems = clip_problems(face)
        else:
            problems = []
        if problems:
            more = len(problems) - shown
            tail = [f"... and {more} more"] if more > 0 else []
            raise ValueError("\n".join(problems[:shown] + tail))


check_clip_faces()


def clip_inputs(split):
    """Input function: the transcript table, media and word timings of a face's clips of
    ``split`` (train or test), so a changed or missing one is seen before any job."""

    def inputs(wildcards):
        corpus = corpus_settings(wildcards.face)
        if one_video(wildcards.face):
            return {"media": corpus["media"], "segments": at(SEGMENTS, wildcards.face)}
        files = {
            "transcripts": corpus["transcripts"],
            "media": [clip_path(corpus["media"], clip) for clip in corpus[split]],
        }
        if corpus["timings"]:
            files["timings"] = [
                clip_path(corpus["timings"], clip) for clip in corpus[split]
            ]
        return files

    return inputs


def video_script(wildcards):
    """A one-video face's video and its transcript or subtitles."""
    corpus = corpus_settings(wildcards.face)
    return {
        key: corpus[key] for key in ("media", "transcript", "subtitles") if corpus[key]
    }


def sweep_methods():
    """Flow methods of the pyramid-depth sweep: '<estimator>-L<levels>'."""
    out = {}
    for estimator in config["sweeps"]["level_estimators"]:
        base = dict(config["flow"]["methods"].get(estimator, {}).get("settings", {}))
        for levels in config["sweeps"]["pyramid_levels"]:
            out[f"{estimator}-L{levels}"] = {
                "estimator": estimator,
                "settings": {**base, "levels": levels},
            }
    return out


METHODS = {**config["flow"]["methods"], **sweep_methods()}


def method_json(name):
    """The estimator name and settings of flow method ``name``, as JSON."""
    spec = METHODS[name]
    return json.dumps(
        {"estimator": spec["estimator"], "settings": spec.get("settings", {})},
        sort_keys=True,
    )


def method_spec(wildcards):
    """method_json of the {method} wildcard."""
    return method_json(wildcards.method)


def mixed_flows(wildcards):
    """A strategy that refines another (bridge: mixed) reads that database of the same method."""
    refines = STRATEGIES[wildcards.strategy].refines
    if refines is None:
        return {}
    return {"mixed": f"{at(FLOWS, wildcards.face)}/{wildcards.method}/{refines}"}


def clip_regions(wildcards):
    """A clips face's flows are estimated around the mouth (the corpus's regions.json)."""
    if wildcards.face not in CLIP_FACES:
        return {}
    return {"regions": f"{at(CORPUS, wildcards.face)}/regions.json"}


def clip_corpus(wildcards):
    """A face from clips also learns its coarticulation from its corpus's aligned frames
    (their eigenlip coordinates)."""
    if wildcards.face not in CLIP_FACES:
        return {}
    files = {
        "phones": f"{at(CORPUS, wildcards.face)}/phones.tsv",
        "regions": f"{at(CORPUS, wildcards.face)}/regions.json",
        "eigenlips": f"{at(CORPUS, wildcards.face)}/eigenlips.npz",
    }
    if one_video(wildcards.face):  # where its reference utterance is in the video
        files["segments"] = at(SEGMENTS, wildcards.face)
    return files


#: Priority of the jobs of a face from clips. Its chain (corpus, visemes, flows, model,
#: eigenlips, held-out test) is the longest in the workflow and mostly one job at a time;
#: started first, it runs beside the synthetic face's many short jobs instead of alone
#: after them.
CLIP_CHAIN = 10


def first_test_clip(face):
    """The clip of a face's held-out figures (None: the first one measured)."""
    return None if one_video(face) else FACES[face]["corpus"]["test"][0]


def clip_chain_first(wildcards):
    """A job's priority: :data:`CLIP_CHAIN` for a face from clips, else 0."""
    return CLIP_CHAIN if wildcards.face in CLIP_FACES else 0


def model_flows(wildcards):
    """The flow database of a face's model."""
    method, strategy = model_flow(wildcards.face)
    return f"{at(FLOWS, wildcards.face)}/{method}/{strategy}"


def heldout_models(wildcards):
    """The models a held-out evaluation measures: the face's own and evaluation.models."""
    face = wildcards.face
    own = "/".join(model_flow(face))
    models = {f"model:{own}": at(MODEL, face)}
    # a face of the training-clips sweep measures its own model only
    if face not in config["faces"]:
        return models
    for name in config["evaluation"]["models"]:
        if name != own:
            models[f"model:{name}"] = f"{at(VARIANTS, face)}/{name}"
    return models


def heldout_tables():
    """The held-out summary and figures of every configured face with test clips; its sweep."""
    out = []
    for face in config["faces"]:
        if not has_test(face):
            continue
        out += [
            f"{METRICS}/heldout/{face}/summary.csv",
            f"{FIGURES}/heldout/{face}/trajectory.png",
            f"{FIGURES}/heldout/{face}/psnr.png",
            f"{FIGURES}/heldout/{face}/strip.png",
            f"{METRICS}/dub/{face}/summary.csv",
            f"{FIGURES}/dub/{face}/strip.png",
        ]
        if sweep_of(face):
            out += [
                f"{METRICS}/heldout/{face}/training_clips.csv",
                f"{FIGURES}/heldout/{face}/training_clips.png",
            ]
    return out


def sweep_of(face):
    """A face's training-clips sweep, {number of clips: face}, the face itself last (or {})."""
    sweep = {}
    for n in config["sweeps"]["training_clips"]:
        if f"{face}-n{n}" in FACES:
            sweep[n] = f"{face}-n{n}"
    if not sweep:
        return {}
    return {**sweep, len(FACES[face]["corpus"]["train"]): face}


def training_clip_summaries(wildcards):
    """The held-out summaries of a face's training-clips sweep."""
    return [
        f"{METRICS}/heldout/{f}/summary.csv" for f in sweep_of(wildcards.face).values()
    ]


def epe_tables():
    """Per-method, per-strategy EPE tables of the truth face (configured methods: all strategies)."""
    if TRUTH_FACE is None:
        return []
    tables = [
        f"{METRICS}/epe/{TRUTH_FACE}/{m}/{s}.csv"
        for m in config["flow"]["methods"]
        for s in STRATEGIES
    ]
    tables += [f"{METRICS}/epe/{TRUTH_FACE}/{m}/direct.csv" for m in sweep_methods()]
    return tables


def utterance_videos():
    """The mp4 of every configured sentence, for every face."""
    return [
        f"{at(UTTERANCES, face)}/{name}.mp4"
        for face in config["faces"]
        for name in config["sentences"]
    ]


def sync_tables():
    """The sync table of every configured sentence (truth face)."""
    return [f"{METRICS}/sync/{TRUTH_FACE}/{name}.csv" for name in config["sentences"]]


#: A sweep setting in a path (px{px}_fps{fps}): a plain decimal number.
NUMBER = r"\d+(\.\d+)?"


def sync_sweep_points():
    """(sampling, px, fps) of the sync sweep, sorted.

    In each mode of sweeps.sampling, one setting at a time: each
    max_px_per_frame at lipsync.fps, each fps at the configured max_px_per_frame.
    """
    s, lipsync = config["sweeps"], config["lipsync"]
    points = set()
    for sampling in s["sampling"]:
        points |= {(sampling, px, lipsync["fps"]) for px in s["max_px_per_frame"]}
        if lipsync["max_px_per_frame"] is not None:  # null: no limit to sweep fps at
            points |= {(sampling, lipsync["max_px_per_frame"], fps) for fps in s["fps"]}
    return sorted(points)


def configured_point(face, sampling, px, fps):
    """Whether a sweep point is the face's configured sampling, max_px_per_frame and fps,
    with the paper's model (the one the sweeps study)."""
    lipsync = lipsync_options(face)
    return lipsync["model"] == "paper" and (sampling, px, fps) == (
        lipsync["sampling"],
        lipsync["max_px_per_frame"],
        lipsync["fps"],
    )


def sweep_lipsync(face, sampling):
    """The lip-sync settings of a sweep utterance: the face's in ``sampling``, with the
    paper's model whatever the face's own (the sweeps study the paper's sampling)."""
    return canonical(
        {
            **lipsync_options(face),
            "sampling": sampling,
            "model": "paper",
            "trajectory": None,
        }
    )


def sweep_timeline(face, sampling, px, fps):
    """The timeline JSON of the sweep sentence said by ``face`` at one sweep point: at
    the configured point the utterance rule's own, elsewhere the sweep_utterance's."""
    if configured_point(face, sampling, px, fps):
        return f"{at(UTTERANCES, face)}/{config['sweeps']['sentence']}.json"
    return f"{at(UTTERANCES, face)}/sweep/{sampling}/px{px}_fps{fps}.json"


def sync_sweep_tables():
    """The sync table of every sync sweep point (truth face); at the configured point
    the sync rule's own table of the sweep sentence."""
    face = TRUTH_FACE or "none"
    return [
        (
            f"{METRICS}/sync/{face}/{config['sweeps']['sentence']}.csv"
            if configured_point(face, sampling, px, fps)
            else f"{METRICS}/sync_sweep/{face}/{sampling}/px{px}_fps{fps}.csv"
        )
        for sampling, px, fps in sync_sweep_points()
    ]


def strip_max_px():
    """The max_px_per_frame of the sampling strip: lipsync's, or the default for none."""
    px = config["lipsync"]["max_px_per_frame"]
    return defaults.MAX_PX_PER_FRAME if px is None else px


def sampling_strip_timelines():
    """The sweep sentence in each swept sampling mode at the strip's settings (figure face)."""
    return [
        sweep_timeline(FIGURE_FACE, sampling, strip_max_px(), config["lipsync"]["fps"])
        for sampling in config["sweeps"]["sampling"]
    ]


def all_outputs():
    out = [f"{at(VISEMES, face)}/contact_sheet.png" for face in config["faces"]]
    out += [at(MODEL, face) for face in config["faces"]]
    out += utterance_videos()
    out += heldout_tables()
    out += [
        f"{FIGURES}/lipsync_diagram.png",
        f"{FIGURES}/morph_strip.png",
        f"{FIGURES}/sampling_strip.png",
    ]
    if TRUTH_FACE is not None:
        out += [
            f"{METRICS}/flow_epe.csv",
            f"{METRICS}/morph_fidelity.csv",
            f"{METRICS}/sync.csv",
            f"{METRICS}/sync_sweep.csv",
            f"{FIGURES}/epe_vs_levels.png",
            f"{FIGURES}/morph_psnr_vs_alpha.png",
            f"{FIGURES}/sync_vs_max_px.png",
            f"{FIGURES}/sampling_vs_max_px.png",
        ]
    else:
        out.append(f"{METRICS}/SKIPPED.txt")
    if config["metrics"]["motorcycle"]:
        out.append(f"{METRICS}/motorcycle_epe.csv")
    return out
