"""Rule model: assemble the model directory."""

import json

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.building.stages import model_stage

    model_stage(
        snakemake.output[0],
        visemes=snakemake.input.visemes,
        images=snakemake.input.images,
        flows=snakemake.input.flows,
        spec=json.loads(snakemake.params.spec),
        strategy=snakemake.params.strategy,
        grouping=snakemake.params.get("grouping", {}),
        phones=snakemake.input.get("phones"),
        eigenlips=snakemake.input.get("eigenlips"),
        media=snakemake.params.get("media"),
        segments=snakemake.input.get("segments"),
    )


run_stage(snakemake, main)
