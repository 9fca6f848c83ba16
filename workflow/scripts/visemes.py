"""Rule visemes: find every target's frame, pick the 16 visemes, draw the sheets."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.extract import extract_visemes_stage

    extract_visemes_stage(
        corpus_dir=Path(snakemake.input.audio).parent,
        grouping=snakemake.params.grouping,
        frames_table=snakemake.params.frames_table,
        out=snakemake.output,
    )


run_stage(snakemake, main)
