"""Rules sync_table and sync_sweep_table: merge sync tables, one summary row per utterance."""

from miketalk.stage import run_stage


def main() -> None:
    import pandas as pd

    from miketalk.media.atomic import write_text_atomic
    from miketalk_lab.evaluation.sync import summarize_sync

    table = pd.concat([pd.read_csv(p, keep_default_na=False) for p in snakemake.input])
    write_text_atomic(snakemake.output.table, table.to_csv(index=False, float_format="%.6g"))
    summary = summarize_sync(table)
    write_text_atomic(snakemake.output.summary, summary.to_csv(index=False, float_format="%.4f"))


run_stage(snakemake, main)
