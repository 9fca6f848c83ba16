# The talking-face model of each face: viseme images + the chosen flow database + a manifest.


rule eigenlips:
    input:
        frames=rules.corpus_clips.output.frames,
        regions=rules.corpus_clips.output.regions,
    output:
        f"{CORPUS}/eigenlips.npz",
    log:
        "results/logs/eigenlips/{face}.log",
    benchmark:
        "results/benchmarks/eigenlips/{face}.tsv"
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/eigenlips.py"


rule model:
    input:
        unpack(clip_corpus),
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        flows=model_flows,
    output:
        directory(MODEL),
    log:
        "results/logs/model/{face}.log",
    wildcard_constraints:
        face=one_of(FACES),
    priority: clip_chain_first
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=lambda wildcards: method_json(model_flow(wildcards.face)[0]),
        strategy=lambda wildcards: model_flow(wildcards.face)[1],
        grouping=canonical(config["visemes"]["grouping"]),
        media=lambda wildcards: corpus_settings(wildcards.face).get("media"),
    script:
        "../scripts/model.py"
