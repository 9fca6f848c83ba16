"""Rule dub_heldout: each held-out clip dubbed with its own audio, compared with its video."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.eigenlips import read_eigenlips
    from miketalk.corpus.one_video import face_clips
    from miketalk_lab.evaluation.dub_heldout import dub_heldout, dub_renderer
    from miketalk_lab.figures.dub_strip import strip

    corpus = snakemake.params.corpus
    clips = face_clips(corpus, "test", segments=snakemake.input.get("segments"))
    dub_heldout(
        model_dir=snakemake.input.model,
        corpus_dir=Path(snakemake.input.words).parent,
        clips=clips,
        out_dir=snakemake.output.videos,
        clips_csv=snakemake.output.clips,
        summary_csv=snakemake.output.summary,
        strip_png=snakemake.output.strip,
        draw_strip=strip,
        corpus_eigenlips=read_eigenlips(snakemake.input.eigenlips),
        renderer=dub_renderer(snakemake.params.lipsync_model, snakemake.input.model),
        morph=snakemake.params.morph,
    )


run_stage(snakemake, main)
