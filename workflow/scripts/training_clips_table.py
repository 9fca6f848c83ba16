"""Rule training_clips_table: the held-out summaries of a training-clips sweep in one table."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.media.atomic import write_text_atomic
    from miketalk_lab.evaluation.heldout import sweep_table

    table = sweep_table(dict(zip(snakemake.params.training_clips, snakemake.input, strict=True)))
    write_text_atomic(snakemake.output[0], table.to_csv(index=False, float_format="%.4f"))


run_stage(snakemake, main)
