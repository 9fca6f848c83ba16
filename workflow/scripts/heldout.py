"""Rule heldout: re-synthesize a face's held-out clips and compare them with their real video."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.eigenlips import read_eigenlips
    from miketalk.corpus.one_video import face_clips
    from miketalk_lab.evaluation.heldout import heldout_stage

    corpus = snakemake.params.corpus
    clips = face_clips(corpus, "test", segments=snakemake.input.get("segments"))
    models = {
        name.removeprefix("model:"): path
        for name, path in snakemake.input.items()
        if name.startswith("model:")
    }
    heldout_stage(
        corpus_dir=Path(snakemake.input.words).parent,
        models=models,
        default_model=snakemake.params.default_model,
        clips=clips,
        grouping=snakemake.params.grouping,
        morph=snakemake.params.morph,
        frames_csv=snakemake.output.frames,
        clips_csv=snakemake.output.clips,
        summary_csv=snakemake.output.summary,
        videos_dir=snakemake.output.videos,
        corpus_eigenlips=read_eigenlips(snakemake.input.eigenlips),
    )


run_stage(snakemake, main)
