# Each configured sentence as a talking-face mp4 with its timeline.


rule utterance:
    input:
        model=rules.model.output[0],
    output:
        video=report(
            f"results/utterances/{FACE}/{{sentence}}.mp4",
            caption="../report/utterance.rst",
            category="Utterances",
        ),
        timeline=f"results/utterances/{FACE}/{{sentence}}.json",
    log:
        f"results/logs/utterances/{FACE}/{{sentence}}.log",
    benchmark:
        f"results/benchmarks/utterances/{FACE}/{{sentence}}.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        text=lambda wildcards: config["sentences"][wildcards.sentence],
        fps=config["lipsync"]["fps"],
        max_px=config["lipsync"]["max_px_per_frame"],
        morph=config["morph"],
    script:
        "../scripts/utterance.py"
