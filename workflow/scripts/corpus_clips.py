"""Rule corpus_clips: a face's training clips of ordinary speech (or the training utterances
of its one video) into the corpus folder."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.building.stages import corpus_stage

    corpus_stage(
        Path(snakemake.output.audio).parent,
        snakemake.params.corpus,
        segments=snakemake.input.get("segments"),
        workers=snakemake.threads,
    )


run_stage(snakemake, main)
