"""Rules sync and sync_sweep_point: a sentence's lip-sync against the synthetic face."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.evaluation.sync import sync_table
    from miketalk.evaluation.tables import read_mask
    from miketalk.media.atomic import write_text_atomic
    from miketalk.talk.say import open_model
    from miketalk.visemes import VisemeTable

    wildcards = snakemake.wildcards
    if "px" in wildcards.keys():
        name = snakemake.params.name
        fps, max_px = float(wildcards.fps), float(wildcards.px)
    else:
        name = wildcards.sentence
        fps, max_px = snakemake.params.fps, snakemake.params.max_px
    table = sync_table(
        name=name,
        text=snakemake.params.text,
        model=open_model(snakemake.input.model, morph_options=snakemake.params.morph),
        table=VisemeTable(grouping=snakemake.params.grouping),
        mouth=read_mask(snakemake.input.mouth),
        fps=fps,
        max_px_per_frame=max_px,
    )
    if "video" in snakemake.input.keys():
        from miketalk.media.video import probe_durations

        video_s, audio_s = probe_durations(snakemake.input.video)
        for quantity, value in (("mp4_video_seconds", video_s), ("mp4_audio_seconds", audio_s)):
            table.loc[len(table)] = {**table.iloc[0].to_dict(), "quantity": quantity,
                                     "key": "", "value": value}  # fmt: skip
    write_text_atomic(snakemake.output[0], table.to_csv(index=False, float_format="%.6g"))


run_stage(snakemake, main)
