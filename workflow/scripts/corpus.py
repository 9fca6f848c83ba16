"""Rule corpus: record the synthetic subject, or ingest a person's video."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.corpus.ingest import ingest_video
    from miketalk.errors import MiketalkError
    from miketalk.speech import get_backend
    from miketalk.visemes import VisemeTable

    corpus = snakemake.params.corpus
    table = VisemeTable(grouping=snakemake.params.grouping)
    chosen = set(corpus["words"] or table.corpus_words())
    if unknown := sorted(chosen - set(table.corpus_words())):
        raise MiketalkError(f"corpus.words names words not in the corpus: {unknown}")
    # spoken in the corpus order (Figure 3), whatever order the config lists them in
    words = [w for w in table.corpus_words() if w in chosen]
    needed = {table.representative(v).word for v in table.visemes} - {"-"}
    if missing := sorted(needed - set(words)):
        raise MiketalkError(f"corpus.words lacks words that visemes are taken from: {missing}")
    out = Path(snakemake.output.audio).parent
    festival = get_backend()
    if corpus["source"] == "synthetic":
        from synth_face.recording import record_corpus

        record_corpus(
            out,
            backend=festival,
            table=table,
            size=corpus["size"],
            fps=corpus["fps"],
            words=words,
        )
    else:
        if not corpus["video"]:
            raise MiketalkError("corpus.source is video but corpus.video is not set")
        ingest_video(
            corpus["video"], out, words=words, backend=festival,
            crop=corpus["video_crop"], width=corpus["video_width"],
        )  # fmt: skip


run_stage(snakemake, main)
