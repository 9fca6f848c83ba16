"""Rule visemes_clips: a candidate frame per phone, the medoid of each viseme class, the sheet."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.viseme_choice import choose_visemes_stage

    choose_visemes_stage(
        corpus_dir=Path(snakemake.input.words).parent,
        grouping=snakemake.params.grouping,
        out=snakemake.output,
    )


run_stage(snakemake, main)
