# The recorded corpus: the synthetic subject, or a person's video, speaking Figure 3's words.


rule corpus:
    output:
        frames=directory(f"{CORPUS}/frames"),
        audio=f"{CORPUS}/audio.wav",
        words=f"{CORPUS}/words.json",
        table=f"{CORPUS}/frames.tsv",
        truth=f"{CORPUS}/truth.tsv",
        video=f"{CORPUS}/corpus.mp4",
    params:
        corpus=config["corpus"],
        grouping=config["visemes"]["grouping"],
    log:
        f"logs/corpus/{FACE}.log",
    benchmark:
        f"benchmarks/corpus/{FACE}.tsv"
    resources:
        mem_mb=4000,
        runtime=30,
    script:
        "../scripts/corpus.py"
