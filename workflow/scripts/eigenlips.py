"""Rule eigenlips: a face's corpus eigenlips, fitted once for its model and its held-out test."""

from miketalk.stage import run_stage


def main() -> None:
    from pathlib import Path

    from miketalk.building.stages import eigenlips_stage

    eigenlips_stage(Path(snakemake.input.regions).parent, snakemake.output[0])


run_stage(snakemake, main)
