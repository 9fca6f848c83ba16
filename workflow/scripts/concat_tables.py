"""Merge tidy CSV tables into one, with a summary by everything but the pair columns."""

from miketalk.stage import run_stage


def main() -> None:
    import pandas as pd

    from miketalk.media.atomic import write_text_atomic

    table = pd.concat([pd.read_csv(path) for path in snakemake.input], ignore_index=True)
    write_text_atomic(snakemake.output.table, table.to_csv(index=False, float_format="%.6g"))
    keys = [c for c in ("method", "estimator", "levels", "strategy", "region") if c in table]
    values = [c for c in ("mean_epe", "pct_over_1px", "pct_over_3px") if c in table]
    summary = table.groupby(keys, dropna=False)[values].mean().reset_index()
    write_text_atomic(snakemake.output.summary, summary.to_csv(index=False, float_format="%.4f"))


run_stage(snakemake, main)
