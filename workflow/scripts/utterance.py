"""Rule utterance: one sentence as an mp4."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.talk.say import open_model, say

    model = open_model(snakemake.input.model, morph_options=snakemake.params.morph)
    say(
        snakemake.params.text,
        snakemake.output.video,
        model=model,
        fps=snakemake.params.fps,
        max_px_per_frame=snakemake.params.max_px,
    )


run_stage(snakemake, main)
