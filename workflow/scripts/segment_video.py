"""Rule segment_video: a one-video face's words aligned and its utterances cut at pauses."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.one_video import segment_video

    segment_video(
        snakemake.input.media,
        snakemake.output[0],
        transcript=snakemake.input.get("transcript"),
        subtitles=snakemake.input.get("subtitles"),
        heldout_seconds=snakemake.params.heldout_seconds,
    )


run_stage(snakemake, main)
