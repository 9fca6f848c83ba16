# Figures drawn from the tidy tables (and two drawn from the model itself).


rule figure_epe_vs_levels:
    input:
        flow_epe_csv=rules.flow_epe_table.output.table,
    output:
        report(
            paths.EPE_VS_LEVELS_FIGURE,
            caption="../report/epe_vs_levels.rst",
            category="Optical flow",
        ),
    log:
        paths.log("figures/epe_vs_levels"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="epe_vs_levels",
    script:
        "../scripts/figures.py"


rule figure_morph_psnr:
    input:
        morph_csv=rules.morph_fidelity.output.table,
    output:
        report(
            paths.MORPH_PSNR_FIGURE,
            caption="../report/morph_psnr_vs_alpha.rst",
            category="Morphing",
        ),
    log:
        paths.log("figures/morph_psnr_vs_alpha"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="morph_psnr_vs_alpha",
    script:
        "../scripts/figures.py"


rule figure_sync_sweep:
    input:
        summary_csv=rules.sync_sweep_table.output.summary,
    output:
        report(
            paths.SYNC_VS_MAX_PX_FIGURE,
            caption="../report/sync_vs_max_px.rst",
            category="Lip-sync",
        ),
    log:
        paths.log("figures/sync_vs_max_px"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="sync_vs_max_px",
    script:
        "../scripts/figures.py"


rule figure_lipsync_diagram:
    input:
        model_dir=paths.at(rules.model.output[0], experiment.figure_face),
    output:
        report(
            paths.LIPSYNC_DIAGRAM_FIGURE,
            caption="../report/lipsync_diagram.rst",
            category="Lip-sync",
        ),
    log:
        paths.log("figures/lipsync_diagram"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="lipsync_diagram",
        word="one",
        fps=config["lipsync"]["fps"],
        max_px=config["lipsync"]["max_px_per_frame"],
    script:
        "../scripts/figures.py"


rule figure_morph_strip:
    input:
        model_dir=paths.at(rules.model.output[0], experiment.figure_face),
    output:
        report(
            paths.MORPH_STRIP_FIGURE,
            caption="../report/morph_strip.rst",
            category="Morphing",
        ),
    log:
        paths.log("figures/morph_strip"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="morph_strip",
        pair=["p", "aa"],
        alphas=[0.25, 0.5, 0.75],
        morph=canonical(config["morph"]),
    script:
        "../scripts/figures.py"


rule figure_sampling_modes:
    input:
        summary_csv=rules.sync_sweep_table.output.summary,
    output:
        report(
            paths.SAMPLING_VS_MAX_PX_FIGURE,
            caption="../report/sampling_vs_max_px.rst",
            category="Lip-sync",
        ),
    log:
        paths.log("figures/sampling_vs_max_px"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="sampling_vs_max_px",
        fps=config["lipsync"]["fps"],
    script:
        "../scripts/figures.py"


rule figure_sampling_strip:
    input:
        model_dir=paths.at(rules.model.output[0], experiment.figure_face),
        timelines=targets.sampling_strip_timelines(experiment),
    output:
        report(
            paths.SAMPLING_STRIP_FIGURE,
            caption="../report/sampling_strip.rst",
            category="Lip-sync",
        ),
    log:
        paths.log("figures/sampling_strip"),
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="sampling_strip",
        morph=experiment.morph_options(experiment.figure_face),
        columns=8,
    script:
        "../scripts/figures.py"
