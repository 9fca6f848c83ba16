"""Rules sync and sync_sweep_point: lip-sync of an utterance the utterance script made."""

from miketalk.stage import run_stage


def main() -> None:
    import json

    from miketalk.media.atomic import write_text_atomic
    from miketalk.model.face import open_model
    from miketalk.talk.utterance import read_said
    from miketalk.visemes import VisemeTable
    from miketalk_lab.evaluation.sync import sync_table
    from miketalk_lab.evaluation.tables import read_mask

    inputs, params = snakemake.input, snakemake.params
    # the measures of the motion as say made them (with the frames it wrote)
    with open(inputs.timeline, encoding="utf-8") as f:
        motion = json.load(f)["motion"]
    table = sync_table(
        name=params.name,
        said=read_said(inputs.timeline),
        model=open_model(inputs.model, morph_options=params.morph),
        table=VisemeTable(grouping=params.grouping),
        mouth=read_mask(inputs.mouth),
        video=inputs.video,
        motion=motion,
    )
    write_text_atomic(snakemake.output[0], table.to_csv(index=False, float_format="%.6g"))


run_stage(snakemake, main)
