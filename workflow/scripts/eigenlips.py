"""Rule eigenlips: a face's corpus eigenlips, fitted once for its model and its held-out test."""

from miketalk.stage import run_stage


def main() -> None:
    from pathlib import Path

    from miketalk.corpus.eigenlips import fit_corpus_eigenlips, write_eigenlips

    corpus_dir = Path(snakemake.input.regions).parent
    write_eigenlips(snakemake.output[0], fit_corpus_eigenlips(corpus_dir))


run_stage(snakemake, main)
