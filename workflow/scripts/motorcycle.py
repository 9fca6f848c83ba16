"""Rule motorcycle: every configured flow method on the Middlebury motorcycle pair."""

from miketalk.stage import run_stage


def main() -> None:
    import pandas as pd

    from miketalk.flow import get_estimator
    from miketalk.media.atomic import write_text_atomic
    from miketalk_lab.evaluation.flow_error import motorcycle_table

    rows = []
    for name, spec in snakemake.params.methods.items():
        estimator = get_estimator(spec["estimator"], **spec.get("settings", {}))
        row = motorcycle_table([estimator]).assign(method=name)
        rows.append(row.drop(columns=["seconds"]))  # timings belong in make bench
    table = pd.concat(rows, ignore_index=True)
    write_text_atomic(snakemake.output[0], table.to_csv(index=False, float_format="%.6g"))


run_stage(snakemake, main)
