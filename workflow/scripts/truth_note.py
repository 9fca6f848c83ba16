"""Rule truth_note: say which measurements were skipped, and why."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.media.atomic import write_text_atomic

    write_text_atomic(
        snakemake.output[0],
        "This run's corpus is a person's recording (corpus.source: video), so there is no\n"
        "ground truth: flow endpoint error, morph fidelity and the sync checks against the\n"
        "synthetic face were skipped. The viseme extraction table has no true frames.\n",
    )


run_stage(snakemake, main)
