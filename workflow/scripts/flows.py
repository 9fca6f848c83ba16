"""Rule flows: one flow database for a method (estimator + settings) and strategy."""

import json
from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    import pandas as pd

    from miketalk.flow.build import build_flow_database
    from miketalk.media.atomic import write_text_atomic
    from miketalk.mouth import flow_region

    spec = json.loads(snakemake.params.spec)
    regions = snakemake.input.get("regions")  # a face from clips: flows around the mouth only
    visemes = pd.read_csv(snakemake.input.visemes, sep="\t", keep_default_na=False)
    choices = build_flow_database(
        snakemake.output.flows,
        visemes=visemes,
        images_dir=Path(snakemake.input.images),
        frames_dir=Path(snakemake.input.frames),
        estimator=spec["estimator"],
        settings=spec["settings"],
        strategy=snakemake.wildcards.strategy,
        window=snakemake.params.window,
        mixed=snakemake.input.get("mixed"),
        region=flow_region(Path(regions).parent) if regions else None,
        workers=snakemake.threads,
    )
    write_text_atomic(snakemake.output.choices, choices.to_csv(sep="\t", index=False))


run_stage(snakemake, main)
