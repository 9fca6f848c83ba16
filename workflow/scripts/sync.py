"""Rules sync and sync_sweep_point: lip-sync of an utterance the utterance script made."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.evaluation.sync import sync_table
    from miketalk.evaluation.tables import read_mask
    from miketalk.media.atomic import write_text_atomic
    from miketalk.talk.say import open_model, read_said
    from miketalk.visemes import VisemeTable

    inputs, params = snakemake.input, snakemake.params
    table = sync_table(
        name=params.name,
        said=read_said(inputs.timeline),
        model=open_model(inputs.model, morph_options=params.morph),
        table=VisemeTable(grouping=params.grouping),
        mouth=read_mask(inputs.mouth),
        video=inputs.video,
    )
    write_text_atomic(snakemake.output[0], table.to_csv(index=False, float_format="%.6g"))


run_stage(snakemake, main)
