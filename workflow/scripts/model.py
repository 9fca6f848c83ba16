"""Rule model: assemble the model directory."""

import json
from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    import pandas as pd

    from miketalk.talk.build import build_model, fallbacks_of

    spec = json.loads(snakemake.params.spec)
    visemes = pd.read_csv(snakemake.input.visemes, sep="\t", keep_default_na=False)
    images = {
        v: Path(snakemake.input.images) / name
        for v, name in zip(visemes["viseme"], visemes["image"], strict=True)
    }
    build_model(
        snakemake.output[0],
        images=images,
        flows_dir=snakemake.input.flows,
        estimator=spec["estimator"],
        settings={**spec["settings"], "strategy": snakemake.params.strategy},
        fallbacks=fallbacks_of(visemes),
    )
    if phones := snakemake.input.get("phones"):  # a face from clips: learn from its frames
        from miketalk.corpus.eigenlips import read_eigenlips
        from miketalk.talk.coarticulation import fit_coarticulation
        from miketalk.talk.trained import fit_trained

        corpus = Path(phones).parent
        fit_coarticulation(
            corpus,
            snakemake.output[0],
            grouping=snakemake.params.grouping,
            corpus_eigenlips=read_eigenlips(snakemake.input.eigenlips),
        )
        fit_trained(corpus, snakemake.output[0], grouping=snakemake.params.grouping)
        if media := snakemake.params.get("media"):  # its person's own frames, for say and dub
            from miketalk.talk.background_files import write_background

            write_background(snakemake.output[0], corpus_dir=corpus, media=media)


run_stage(snakemake, main)
