"""Rule morph_fidelity: morphs vs the true in-between renders."""

from miketalk.stage import run_stage


def main() -> None:
    import pandas as pd

    from miketalk.media.atomic import write_text_atomic
    from miketalk_lab.evaluation.tables import morph_fidelity_table

    visemes = pd.read_csv(snakemake.input.visemes, sep="\t", keep_default_na=False)
    table = morph_fidelity_table(
        visemes=visemes,
        images_dir=snakemake.input.images,
        flows_dir=snakemake.input.flows,
        truth_dir=snakemake.input.truth,
        frames_tsv=snakemake.input.table,
        mouth_mask=snakemake.input.mouth,
        alphas=snakemake.params.alphas,
        morph_options=snakemake.params.morph,
    )
    write_text_atomic(snakemake.output.table, table.to_csv(index=False, float_format="%.6g"))
    summary = (
        table.groupby(["candidate", "region", "alpha"])[["psnr", "ssim", "holes_left"]]
        .agg({"psnr": "mean", "ssim": "mean", "holes_left": "max"})
        .reset_index()
    )
    write_text_atomic(snakemake.output.summary, summary.to_csv(index=False, float_format="%.4f"))


run_stage(snakemake, main)
