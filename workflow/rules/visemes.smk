# Viseme extraction: each corpus target's frame, then the 16 visemes (paper section 4).


rule visemes:
    input:
        frames=rules.corpus.output.frames,
        audio=rules.corpus.output.audio,
        words=rules.corpus.output.words,
        truth=rules.corpus.output.truth,
    output:
        targets=report(
            f"{VISEMES}/targets.tsv",
            caption="../report/targets.rst",
            category="Visemes",
        ),
        visemes=f"{VISEMES}/visemes.tsv",
        images=directory(f"{VISEMES}/images"),
        sheet=report(
            f"{VISEMES}/contact_sheet.png",
            caption="../report/contact_sheet.rst",
            category="Visemes",
        ),
        strip=report(
            f"{VISEMES}/word_strip.png",
            caption="../report/word_strip.rst",
            category="Visemes",
        ),
    log:
        f"results/logs/visemes/{FACE}.log",
    benchmark:
        f"results/benchmarks/visemes/{FACE}.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        grouping=config["visemes"]["grouping"],
        frames_table=config["visemes"]["frames_table"],
    script:
        "../scripts/visemes.py"
