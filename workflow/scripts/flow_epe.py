"""Rule flow_epe: endpoint error of one flow database against the true flows."""

import json

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.media.atomic import write_text_atomic
    from miketalk_lab.evaluation.tables import flow_epe_table

    spec = json.loads(snakemake.params.spec)
    table = flow_epe_table(
        snakemake.input.flows,
        snakemake.input.truth,
        snakemake.input.mouth,
        method=snakemake.wildcards.method,
        estimator=spec["estimator"],
        settings=spec["settings"],
        strategy=snakemake.wildcards.strategy,
    )
    write_text_atomic(snakemake.output[0], table.to_csv(index=False, float_format="%.6g"))


run_stage(snakemake, main)
