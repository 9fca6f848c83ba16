# The talking-face model of each face: viseme images + the chosen flow database + a manifest.


rule eigenlips:
    input:
        frames=rules.corpus_clips.output.frames,
        regions=rules.corpus_clips.output.regions,
    output:
        paths.EIGENLIPS,
    log:
        paths.log("eigenlips/{face}"),
    benchmark:
        paths.benchmark("eigenlips/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/eigenlips.py"


rule model:
    input:
        unpack(inputs.clip_corpus),
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        flows=inputs.model_flows,
    output:
        directory(paths.MODEL),
    log:
        paths.log("model/{face}"),
    wildcard_constraints:
        face=paths.one_of(experiment.faces),
    priority: inputs.clip_chain_first
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=lambda wildcards: experiment.method_json(
            experiment.model_flow(wildcards.face)[0]
        ),
        strategy=lambda wildcards: experiment.model_flow(wildcards.face)[1],
        grouping=experiment.grouping,
        media=lambda wildcards: experiment.corpus_settings(wildcards.face).get("media"),
    script:
        "../scripts/model.py"
