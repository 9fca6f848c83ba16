# Measured against a real person: each face built from clips re-synthesizes its held-out
# clips from their own audio and is compared frame by frame with their real video.


rule model_variant:
    input:
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        flows=paths.FLOW_DATABASE,
    output:
        directory(paths.VARIANT),
    log:
        paths.log("model_variant/{face}/{method}/{strategy}"),
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=inputs.method_spec,
        strategy=lambda wildcards: wildcards.strategy,
    script:
        "../scripts/model.py"


rule heldout:
    input:
        unpack(inputs.heldout_models),
        unpack(inputs.clip_inputs("test")),
        words=rules.corpus_clips.output.words,
        regions=rules.corpus_clips.output.regions,
        reference=rules.corpus_clips.output.reference,
        registration_mask=rules.corpus_clips.output.registration_mask,
        eigenlips=rules.eigenlips.output[0],
    output:
        frames=paths.HELDOUT_FRAMES,
        clips=paths.HELDOUT_CLIPS,
        summary=report(
            paths.HELDOUT_SUMMARY,
            caption="../report/heldout.rst",
            category="Real person",
        ),
        videos=directory(paths.HELDOUT_VIDEOS),
    log:
        paths.log("heldout/{face}"),
    benchmark:
        paths.benchmark("heldout/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        corpus=lambda wildcards: experiment.corpus_settings(wildcards.face),
        default_model=lambda wildcards: "/".join(experiment.model_flow(wildcards.face)),
        grouping=experiment.grouping,
        morph=lambda wildcards: experiment.morph_options(wildcards.face),
    script:
        "../scripts/heldout.py"


rule dub_heldout:
    input:
        unpack(inputs.clip_inputs("test")),
        unpack(inputs.crop_dub_inputs),
        model=rules.model.output[0],
        words=rules.corpus_clips.output.words,
        regions=rules.corpus_clips.output.regions,
        eigenlips=rules.eigenlips.output[0],
    output:
        clips=paths.DUB_CLIPS,
        summary=report(
            paths.DUB_SUMMARY,
            caption="../report/dub.rst",
            category="Real person",
        ),
        strip=report(
            paths.DUB_STRIP_FIGURE,
            caption="../report/dub.rst",
            category="Real person",
        ),
        videos=directory(paths.DUB_VIDEOS),
    log:
        paths.log("dub_heldout/{face}"),
    benchmark:
        paths.benchmark("dub_heldout/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    conda:
        "../envs/miketalk.yaml"
    params:
        corpus=lambda wildcards: experiment.corpus_settings(wildcards.face),
        lipsync_model=lambda wildcards: experiment.recording_model(wildcards.face),
        morph=lambda wildcards: experiment.morph_options(wildcards.face),
    script:
        "../scripts/dub_heldout.py"


rule training_clips_table:
    input:
        inputs.training_clip_summaries,
    output:
        paths.TRAINING_CLIPS_TABLE,
    log:
        paths.log("training_clips_table/{face}"),
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    conda:
        "../envs/miketalk.yaml"
    params:
        training_clips=lambda wildcards: list(experiment.sweep_of(wildcards.face)),
    script:
        "../scripts/training_clips_table.py"


rule figure_heldout:
    input:
        frames_csv=rules.heldout.output.frames,
        videos=rules.heldout.output.videos,
        regions=rules.corpus_clips.output.regions,
    output:
        trajectory=report(
            paths.HELDOUT_TRAJECTORY_FIGURE,
            caption="../report/heldout_trajectory.rst",
            category="Real person",
        ),
        psnr=report(
            paths.HELDOUT_PSNR_FIGURE,
            caption="../report/heldout_psnr.rst",
            category="Real person",
        ),
        strip=report(
            paths.HELDOUT_STRIP_FIGURE,
            caption="../report/heldout_strip.rst",
            category="Real person",
        ),
    log:
        paths.log("figures/heldout/{face}"),
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        clip=lambda wildcards: experiment.first_test_clip(wildcards.face),
        model=lambda wildcards: "/".join(experiment.model_flow(wildcards.face)),
    script:
        "../scripts/heldout_figures.py"


rule figure_training_clips:
    input:
        sweep_csv=rules.training_clips_table.output[0],
    output:
        report(
            paths.TRAINING_CLIPS_FIGURE,
            caption="../report/training_clips.rst",
            category="Real person",
        ),
    log:
        paths.log("figures/training_clips/{face}"),
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="training_clips",
    script:
        "../scripts/figures.py"
