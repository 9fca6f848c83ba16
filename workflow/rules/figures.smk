# Figures drawn from the tidy tables (and two drawn from the model itself).


rule figure_epe_vs_levels:
    input:
        flow_epe_csv=rules.flow_epe_table.output.table,
    output:
        report(
            f"{FIGURES}/epe_vs_levels.png",
            caption="../report/epe_vs_levels.rst",
            category="Optical flow",
        ),
    log:
        "results/logs/figures/epe_vs_levels.log",
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
            f"{FIGURES}/morph_psnr_vs_alpha.png",
            caption="../report/morph_psnr_vs_alpha.rst",
            category="Morphing",
        ),
    log:
        "results/logs/figures/morph_psnr_vs_alpha.log",
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
            f"{FIGURES}/sync_vs_max_px.png",
            caption="../report/sync_vs_max_px.rst",
            category="Lip-sync",
        ),
    log:
        "results/logs/figures/sync_vs_max_px.log",
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="sync_vs_max_px",
    script:
        "../scripts/figures.py"


rule figure_lipsync_diagram:
    input:
        model_dir=at(rules.model.output[0], FIGURE_FACE),
    output:
        report(
            f"{FIGURES}/lipsync_diagram.png",
            caption="../report/lipsync_diagram.rst",
            category="Lip-sync",
        ),
    log:
        "results/logs/figures/lipsync_diagram.log",
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
        model_dir=at(rules.model.output[0], FIGURE_FACE),
    output:
        report(
            f"{FIGURES}/morph_strip.png",
            caption="../report/morph_strip.rst",
            category="Morphing",
        ),
    log:
        "results/logs/figures/morph_strip.log",
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
            f"{FIGURES}/sampling_vs_max_px.png",
            caption="../report/sampling_vs_max_px.rst",
            category="Lip-sync",
        ),
    log:
        "results/logs/figures/sampling_vs_max_px.log",
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="sampling_vs_max_px",
        fps=config["lipsync"]["fps"],
    script:
        "../scripts/figures.py"


rule figure_sampling_strip:
    input:
        model_dir=at(rules.model.output[0], FIGURE_FACE),
        timelines=sampling_strip_timelines(),
    output:
        report(
            f"{FIGURES}/sampling_strip.png",
            caption="../report/sampling_strip.rst",
            category="Lip-sync",
        ),
    log:
        "results/logs/figures/sampling_strip.log",
    conda:
        "../envs/miketalk.yaml"
    params:
        figure="sampling_strip",
        morph=morph_options(FIGURE_FACE),
        columns=8,
    script:
        "../scripts/figures.py"
