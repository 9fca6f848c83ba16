# Measured against a real person: each face built from clips re-synthesizes its held-out
# clips from their own audio and is compared frame by frame with their real video.


rule model_variant:
    input:
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        flows=f"{FLOWS}/{{method}}/{{strategy}}",
    output:
        directory(f"{VARIANTS}/{{method}}/{{strategy}}"),
    log:
        "results/logs/model_variant/{face}/{method}/{strategy}.log",
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=method_spec,
        strategy=lambda wildcards: wildcards.strategy,
    script:
        "../scripts/model.py"


rule heldout:
    input:
        unpack(heldout_models),
        unpack(clip_inputs("test")),
        words=rules.corpus_clips.output.words,
        regions=rules.corpus_clips.output.regions,
        reference=rules.corpus_clips.output.reference,
        registration_mask=rules.corpus_clips.output.registration_mask,
        eigenlips=rules.eigenlips.output[0],
    output:
        frames=f"{METRICS}/heldout/{{face}}/frames.csv",
        clips=f"{METRICS}/heldout/{{face}}/clips.csv",
        summary=report(
            f"{METRICS}/heldout/{{face}}/summary.csv",
            caption="../report/heldout.rst",
            category="Real person",
        ),
        videos=directory("results/heldout/{face}"),
    log:
        "results/logs/heldout/{face}.log",
    benchmark:
        "results/benchmarks/heldout/{face}.tsv"
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        corpus=lambda wildcards: corpus_settings(wildcards.face),
        default_model=lambda wildcards: "/".join(model_flow(wildcards.face)),
        grouping=canonical(config["visemes"]["grouping"]),
        morph=lambda wildcards: morph_options(wildcards.face),
    script:
        "../scripts/heldout.py"


rule dub_heldout:
    input:
        unpack(clip_inputs("test")),
        model=rules.model.output[0],
        words=rules.corpus_clips.output.words,
        regions=rules.corpus_clips.output.regions,
        eigenlips=rules.eigenlips.output[0],
    output:
        clips=f"{METRICS}/dub/{{face}}/clips.csv",
        summary=report(
            f"{METRICS}/dub/{{face}}/summary.csv",
            caption="../report/dub.rst",
            category="Real person",
        ),
        strip=report(
            f"{FIGURES}/dub/{{face}}/strip.png",
            caption="../report/dub.rst",
            category="Real person",
        ),
        videos=directory("results/dub/{face}"),
    log:
        "results/logs/dub_heldout/{face}.log",
    benchmark:
        "results/benchmarks/dub_heldout/{face}.tsv"
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    conda:
        "../envs/miketalk.yaml"
    params:
        corpus=lambda wildcards: corpus_settings(wildcards.face),
        lipsync_model=lambda wildcards: recording_model(wildcards.face),
        morph=lambda wildcards: morph_options(wildcards.face),
    script:
        "../scripts/dub_heldout.py"


rule training_clips_table:
    input:
        training_clip_summaries,
    output:
        f"{METRICS}/heldout/{{face}}/training_clips.csv",
    log:
        "results/logs/training_clips_table/{face}.log",
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    conda:
        "../envs/miketalk.yaml"
    params:
        training_clips=lambda wildcards: list(sweep_of(wildcards.face)),
    script:
        "../scripts/training_clips_table.py"


rule figure_heldout:
    input:
        frames_csv=rules.heldout.output.frames,
        videos=rules.heldout.output.videos,
        regions=rules.corpus_clips.output.regions,
    output:
        trajectory=report(
            f"{FIGURES}/heldout/{{face}}/trajectory.png",
            caption="../report/heldout_trajectory.rst",
            category="Real person",
        ),
        psnr=report(
            f"{FIGURES}/heldout/{{face}}/psnr.png",
            caption="../report/heldout_psnr.rst",
            category="Real person",
        ),
        strip=report(
            f"{FIGURES}/heldout/{{face}}/strip.png",
            caption="../report/heldout_strip.rst",
            category="Real person",
        ),
    log:
        "results/logs/figures/heldout/{face}.log",
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        clip=lambda wildcards: first_test_clip(wildcards.face),
        model=lambda wildcards: "/".join(model_flow(wildcards.face)),
    script:
        "../scripts/heldout_figures.py"


rule figure_training_clips:
    input:
        sweep_csv=rules.training_clips_table.output[0],
    output:
        report(
            f"{FIGURES}/heldout/{{face}}/training_clips.png",
            caption="../report/training_clips.rst",
            category="Real person",
        ),
    log:
        "results/logs/figures/training_clips/{face}.log",
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="training_clips",
    script:
        "../scripts/figures.py"
