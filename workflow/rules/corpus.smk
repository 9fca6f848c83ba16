# The recorded corpus of each face: the synthetic subject or a person's video speaking
# Figure 3's words, or clips of a person's ordinary speech.


rule corpus:
    output:
        frames=directory(f"{CORPUS}/frames"),
        audio=f"{CORPUS}/audio.wav",
        words=f"{CORPUS}/words.json",
        table=f"{CORPUS}/frames.tsv",
        truth=f"{CORPUS}/truth.tsv",
        video=f"{CORPUS}/corpus.mp4",
    log:
        "results/logs/corpus/{face}.log",
    benchmark:
        "results/benchmarks/corpus/{face}.tsv"
    wildcard_constraints:
        face=one_of(CORPUS_WORD_FACES),
    conda:
        "../envs/miketalk.yaml"
    resources:
        mem_mb=4000,
        runtime=30,
    params:
        corpus=lambda wildcards: corpus_settings(wildcards.face),
        grouping=canonical(config["visemes"]["grouping"]),
    script:
        "../scripts/corpus.py"


rule segment_video:
    input:
        unpack(video_script),
    output:
        SEGMENTS,
    log:
        "results/logs/segment_video/{face}.log",
    benchmark:
        "results/benchmarks/segment_video/{face}.tsv"
    wildcard_constraints:
        face=one_of(VIDEO_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    resources:
        mem_mb=2000,
        runtime=30,
    params:
        heldout_seconds=lambda wildcards: FACES[wildcards.face]["corpus"][
            "heldout_seconds"
        ],
    script:
        "../scripts/segment_video.py"


rule corpus_clips:
    input:
        unpack(clip_inputs("train")),
    output:
        frames=directory(f"{CORPUS}/frames"),
        audio=f"{CORPUS}/audio.wav",
        words=f"{CORPUS}/words.json",
        table=f"{CORPUS}/frames.tsv",
        truth=f"{CORPUS}/truth.tsv",
        video=f"{CORPUS}/corpus.mp4",
        clips=f"{CORPUS}/clips.tsv",
        phones=f"{CORPUS}/phones.tsv",
        stabilization=f"{CORPUS}/stabilization.tsv",
        skipped=f"{CORPUS}/skipped.tsv",
        regions=f"{CORPUS}/regions.json",
        reference=f"{CORPUS}/reference.png",
        registration_mask=f"{CORPUS}/registration_mask.png",
        face_mask=f"{CORPUS}/face_mask.png",
        mouth_mask=f"{CORPUS}/mouth_mask.png",
    log:
        "results/logs/corpus/{face}.log",
    benchmark:
        "results/benchmarks/corpus/{face}.tsv"
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    threads: 2
    resources:
        mem_mb=4000,
        runtime=30,
    params:
        corpus=lambda wildcards: corpus_settings(wildcards.face),
    script:
        "../scripts/corpus_clips.py"
