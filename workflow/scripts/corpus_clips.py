"""Rule corpus_clips: a face's training clips of ordinary speech (or the training utterances
of its one video) into the corpus folder, in the video's own pixels or, for a face whose
frame is crop, in its tracked face crop (as ``miketalk build`` does)."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.building.stages import corpus_stage
    from miketalk.track.crop import crop_from_doc

    corpus = dict(snakemake.params.corpus)
    crop = crop_from_doc(corpus.pop("crop", None))  # a face built in its face crop only
    corpus_stage(
        Path(snakemake.output.audio).parent,
        corpus,
        segments=snakemake.input.get("segments"),
        workers=snakemake.threads,
        crop=crop,
    )


run_stage(snakemake, main)
