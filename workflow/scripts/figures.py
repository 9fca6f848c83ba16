"""Rules figure_*: each draws one figure with miketalk.figures."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.figures import plots as figures

    rule = snakemake.rule
    out = snakemake.output[0]
    if rule == "figure_epe_vs_levels":
        figures.epe_vs_levels(snakemake.input[0], out)
    elif rule == "figure_morph_psnr":
        figures.morph_psnr_vs_alpha(snakemake.input[0], out)
    elif rule == "figure_sync_sweep":
        figures.sync_vs_max_px(snakemake.input[0], out)
    elif rule == "figure_lipsync_diagram":
        p = snakemake.params
        figures.lipsync_diagram(snakemake.input.model, p.word, out, fps=p.fps, max_px=p.max_px)
    elif rule == "figure_morph_strip":
        p = snakemake.params
        figures.morph_strip(snakemake.input.model, p.pair, p.alphas, out, morph=p.morph)
    else:
        raise ValueError(f"no figure for rule {rule}")


run_stage(snakemake, main)
