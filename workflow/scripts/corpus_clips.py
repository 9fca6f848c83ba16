"""Rule corpus_clips: a face's training clips of ordinary speech into the corpus folder."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.clip_sources import clip_sources
    from miketalk.corpus.clips import ingest_clips

    corpus = snakemake.params.corpus
    clips = clip_sources(
        corpus["train"],
        media=corpus["media"],
        transcripts=corpus["transcripts"],
        timings=corpus["timings"],
    )
    ingest_clips(Path(snakemake.output.audio).parent, clips=clips, workers=snakemake.threads)


run_stage(snakemake, main)
