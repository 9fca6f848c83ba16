"""Rule flows: one flow database for a method (estimator + settings) and strategy."""

import json

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.building.stages import flows_stage

    flows_stage(
        snakemake.output.flows,
        snakemake.output.choices,
        visemes=snakemake.input.visemes,
        images=snakemake.input.images,
        frames=snakemake.input.frames,
        spec=json.loads(snakemake.params.spec),
        strategy=snakemake.wildcards.strategy,
        window=snakemake.params.window,
        mixed=snakemake.input.get("mixed"),
        regions=snakemake.input.get("regions"),
        workers=snakemake.threads,
    )


run_stage(snakemake, main)
