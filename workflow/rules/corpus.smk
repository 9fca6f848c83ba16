# The recorded corpus: the synthetic subject, or a person's video, speaking Figure 3's words.


rule corpus:
    output:
        frames=directory(f"{CORPUS}/frames"),
        audio=f"{CORPUS}/audio.wav",
        words=f"{CORPUS}/words.json",
        table=f"{CORPUS}/frames.tsv",
        truth=f"{CORPUS}/truth.tsv",
        video=f"{CORPUS}/corpus.mp4",
    log:
        f"results/logs/corpus/{FACE}.log",
    benchmark:
        f"results/benchmarks/corpus/{FACE}.tsv"
    conda:
        "../envs/miketalk.yaml"
    resources:
        mem_mb=4000,
        runtime=30,
    params:
        corpus=config["corpus"],
        grouping=config["visemes"]["grouping"],
    script:
        "../scripts/corpus.py"
