# Each configured sentence as a talking-face mp4 with its timeline; and the sync
# sweep's sentence at each of its settings (the same script, sampling mode, max_px and
# fps from the path).


rule utterance:
    input:
        model=rules.model.output[0],
    output:
        video=report(
            paths.UTTERANCE_VIDEO,
            caption="../report/utterance.rst",
            category="Utterances",
        ),
        timeline=paths.UTTERANCE_TIMELINE,
    log:
        paths.log("utterances/{face}/{sentence}"),
    benchmark:
        paths.benchmark("utterances/{face}/{sentence}")
    wildcard_constraints:
        sentence="[^/]+",
        face=paths.one_of(experiment.faces),
    conda:
        "../envs/miketalk.yaml"
    params:
        text=lambda wildcards: config["sentences"][wildcards.sentence],
        fps=config["lipsync"]["fps"],
        max_px=config["lipsync"]["max_px_per_frame"],
        lipsync=lambda wildcards: experiment.lipsync_options(wildcards.face),
        morph=lambda wildcards: experiment.morph_options(wildcards.face),
        grouping=experiment.grouping,
        background=lambda wildcards: experiment.face_background(wildcards.face),
    script:
        "../scripts/utterance.py"


rule sweep_utterance:
    input:
        model=rules.model.output[0],
    output:
        video=paths.SWEEP_VIDEO,
        timeline=paths.SWEEP_TIMELINE,
    log:
        paths.log("utterances/{face}/sweep/{sampling}/px{px}_fps{fps}"),
    benchmark:
        paths.benchmark("utterances/{face}/sweep/{sampling}/px{px}_fps{fps}")
    wildcard_constraints:
        face=paths.one_of(experiment.faces),
        sampling=paths.one_of(vocabulary.SAMPLINGS),
        px=paths.NUMBER,
        fps=paths.NUMBER,
    conda:
        "../envs/miketalk.yaml"
    params:
        text=config["sentences"][config["sweeps"]["sentence"]],
        fps=lambda wildcards: float(wildcards.fps),
        max_px=lambda wildcards: float(wildcards.px),
        lipsync=lambda wildcards: experiment.sweep_lipsync(
            wildcards.face, wildcards.sampling
        ),
        morph=lambda wildcards: experiment.morph_options(wildcards.face),
        grouping=experiment.grouping,
    script:
        "../scripts/utterance.py"
