# The recorded corpus of each face: the synthetic subject or a person's video speaking
# Figure 3's words, or clips of a person's ordinary speech.


rule corpus:
    output:
        frames=directory(paths.CORPUS_FRAMES),
        audio=paths.CORPUS_AUDIO,
        words=paths.CORPUS_WORDS,
        table=paths.CORPUS_TABLE,
        truth=paths.CORPUS_TRUTH,
        video=paths.CORPUS_VIDEO,
    log:
        paths.log("corpus/{face}"),
    benchmark:
        paths.benchmark("corpus/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.corpus_word_faces),
    conda:
        "../envs/miketalk.yaml"
    resources:
        mem_mb=4000,
        runtime=30,
    params:
        corpus=lambda wildcards: experiment.corpus_settings(wildcards.face),
        grouping=experiment.grouping,
    script:
        "../scripts/corpus.py"


rule segment_video:
    input:
        unpack(inputs.video_script),
    output:
        paths.SEGMENTS,
    log:
        paths.log("segment_video/{face}"),
    benchmark:
        paths.benchmark("segment_video/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.video_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    resources:
        mem_mb=2000,
        runtime=30,
    params:
        heldout_seconds=lambda wildcards: experiment.faces[wildcards.face]["corpus"][
            "heldout_seconds"
        ],
    script:
        "../scripts/segment_video.py"


rule corpus_clips:
    input:
        unpack(inputs.clip_inputs("train")),
    output:
        frames=directory(paths.CORPUS_FRAMES),
        audio=paths.CORPUS_AUDIO,
        words=paths.CORPUS_WORDS,
        table=paths.CORPUS_TABLE,
        truth=paths.CORPUS_TRUTH,
        video=paths.CORPUS_VIDEO,
        clips=paths.CORPUS_CLIPS,
        phones=paths.CORPUS_PHONES,
        stabilization=paths.CORPUS_STABILIZATION,
        skipped=paths.CORPUS_SKIPPED,
        regions=paths.CORPUS_REGIONS,
        reference=paths.CORPUS_REFERENCE,
        registration_mask=paths.CORPUS_REGISTRATION_MASK,
        face_mask=paths.CORPUS_FACE_MASK,
        mouth_mask=paths.CORPUS_MOUTH_MASK,
    log:
        paths.log("corpus/{face}"),
    benchmark:
        paths.benchmark("corpus/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    threads: 2
    resources:
        mem_mb=4000,
        runtime=30,
    params:
        corpus=lambda wildcards: experiment.corpus_build_settings(wildcards.face),
    script:
        "../scripts/corpus_clips.py"
