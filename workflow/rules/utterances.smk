# Each configured sentence as a talking-face mp4 with its timeline; and the sync
# sweep's sentence at each of its settings (the same script, sampling mode, max_px and
# fps from the path).


rule utterance:
    input:
        model=rules.model.output[0],
    output:
        video=report(
            f"{UTTERANCES}/{{sentence}}.mp4",
            caption="../report/utterance.rst",
            category="Utterances",
        ),
        timeline=f"{UTTERANCES}/{{sentence}}.json",
    log:
        "results/logs/utterances/{face}/{sentence}.log",
    benchmark:
        "results/benchmarks/utterances/{face}/{sentence}.tsv"
    wildcard_constraints:
        sentence="[^/]+",
        face=one_of(FACES),
    conda:
        "../envs/miketalk.yaml"
    params:
        text=lambda wildcards: config["sentences"][wildcards.sentence],
        fps=config["lipsync"]["fps"],
        max_px=config["lipsync"]["max_px_per_frame"],
        lipsync=lambda wildcards: lipsync_options(wildcards.face),
        morph=lambda wildcards: morph_options(wildcards.face),
        grouping=canonical(config["visemes"]["grouping"]),
        background=lambda wildcards: face_background(wildcards.face),
    script:
        "../scripts/utterance.py"


rule sweep_utterance:
    input:
        model=rules.model.output[0],
    output:
        video=f"{UTTERANCES}/sweep/{{sampling}}/px{{px}}_fps{{fps}}.mp4",
        timeline=f"{UTTERANCES}/sweep/{{sampling}}/px{{px}}_fps{{fps}}.json",
    log:
        "results/logs/utterances/{face}/sweep/{sampling}/px{px}_fps{fps}.log",
    benchmark:
        "results/benchmarks/utterances/{face}/sweep/{sampling}/px{px}_fps{fps}.tsv"
    wildcard_constraints:
        face=one_of(FACES),
        sampling=one_of(SAMPLINGS),
        px=NUMBER,
        fps=NUMBER,
    conda:
        "../envs/miketalk.yaml"
    params:
        text=config["sentences"][config["sweeps"]["sentence"]],
        fps=lambda wildcards: float(wildcards.fps),
        max_px=lambda wildcards: float(wildcards.px),
        lipsync=lambda wildcards: sweep_lipsync(wildcards.face, wildcards.sampling),
        morph=lambda wildcards: morph_options(wildcards.face),
        grouping=canonical(config["visemes"]["grouping"]),
    script:
        "../scripts/utterance.py"
