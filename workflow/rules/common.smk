# Names, paths and lookups shared by the rules.
import json

from miketalk import defaults
from miketalk.flow.strategies import STRATEGIES, get_strategy

FACE = config["face"]
SYNTHETIC = config["corpus"]["source"] == "synthetic"
CORPUS = str(defaults.corpus_dir(FACE))
VISEMES = str(defaults.visemes_dir(FACE))
FLOWS = str(defaults.flows_dir(FACE))
MODEL = str(defaults.model_dir(FACE))
TRUTH = str(defaults.truth_dir(FACE))
METRICS = str(defaults.metrics_dir())
FIGURES = str(defaults.figures_dir())
# an unknown strategy fails here, naming the known ones
get_strategy(config["flow"]["strategy"])


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
    return {"mixed": f"{FLOWS}/{wildcards.method}/{refines}"}


def epe_tables():
    """Per-method, per-strategy EPE tables (configured methods: all strategies)."""
    if not SYNTHETIC:
        return []
    tables = [
        f"{METRICS}/epe/{FACE}/{m}/{s}.csv"
        for m in config["flow"]["methods"]
        for s in STRATEGIES
    ]
    tables += [f"{METRICS}/epe/{FACE}/{m}/direct.csv" for m in sweep_methods()]
    return tables


#: Each sentence's mp4 and timeline JSON; the sync sweep's under sweep/.
UTTERANCES = f"results/utterances/{FACE}"


def utterance_videos():
    """The mp4 of every configured sentence."""
    return [f"{UTTERANCES}/{name}.mp4" for name in config["sentences"]]


def sync_tables():
    """The sync table of every configured sentence."""
    return [f"{METRICS}/sync/{FACE}/{name}.csv" for name in config["sentences"]]


#: A sweep setting in a path (px{px}_fps{fps}): a plain decimal number.
NUMBER = r"\d+(\.\d+)?"


def sync_sweep_tables():
    """One setting at a time: each max_px_per_frame at lipsync.fps, each fps at the default px."""
    s, lipsync = config["sweeps"], config["lipsync"]
    points = [(px, lipsync["fps"]) for px in s["max_px_per_frame"]]
    if lipsync["max_px_per_frame"] is not None:  # null: no oversampling to sweep fps at
        points += [(lipsync["max_px_per_frame"], fps) for fps in s["fps"]]
    default = (lipsync["max_px_per_frame"], lipsync["fps"])
    # the default point is the sync rule's own table of the sweep sentence
    return sorted(
        {
            (
                f"{METRICS}/sync/{FACE}/{s['sentence']}.csv"
                if (px, fps) == default
                else f"{METRICS}/sync_sweep/{FACE}/px{px}_fps{fps}.csv"
            )
            for px, fps in points
        }
    )


def all_outputs():
    out = [
        f"{VISEMES}/contact_sheet.png",
        MODEL,
        *utterance_videos(),
        f"{FIGURES}/lipsync_diagram.png",
        f"{FIGURES}/morph_strip.png",
    ]
    if SYNTHETIC:
        out += [
            f"{METRICS}/flow_epe.csv",
            f"{METRICS}/morph_fidelity.csv",
            f"{METRICS}/sync.csv",
            f"{METRICS}/sync_sweep.csv",
            f"{FIGURES}/epe_vs_levels.png",
            f"{FIGURES}/morph_psnr_vs_alpha.png",
            f"{FIGURES}/sync_vs_max_px.png",
        ]
    else:
        out.append(f"{METRICS}/SKIPPED.txt")
    if config["metrics"]["motorcycle"]:
        out.append(f"{METRICS}/motorcycle_epe.csv")
    return out
