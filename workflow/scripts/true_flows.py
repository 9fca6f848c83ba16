"""Rule true_flows: the synthetic face's true flows between the visemes, and its mouth mask."""

from miketalk.stage import run_stage


def main() -> None:
    import numpy as np
    import pandas as pd

    from miketalk.media.images import write_png
    from miketalk_lab.evaluation.truth import viseme_params, write_true_flows

    visemes = pd.read_csv(snakemake.input.visemes, sep="\t", keep_default_na=False)
    params = viseme_params(snakemake.input.table, visemes)
    mouth = write_true_flows(snakemake.output.flows, params, size=snakemake.params.size)
    write_png(snakemake.output.mouth, (mouth * 255).astype(np.uint8))


run_stage(snakemake, main)
