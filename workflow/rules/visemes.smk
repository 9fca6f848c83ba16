# Viseme images: each corpus target's frame then the 16 visemes (paper section 4), or, for
# clips of ordinary speech, a candidate per phone and the medoid of each class.


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
        "results/logs/visemes/{face}.log",
    benchmark:
        "results/benchmarks/visemes/{face}.tsv"
    wildcard_constraints:
        face=one_of(CORPUS_WORD_FACES),
    conda:
        "../envs/miketalk.yaml"
    params:
        grouping=canonical(config["visemes"]["grouping"]),
        frames_table=project_path(config["visemes"]["frames_table"]),
    script:
        "../scripts/visemes.py"


rule visemes_clips:
    input:
        frames=rules.corpus_clips.output.frames,
        words=rules.corpus_clips.output.words,
        phones=rules.corpus_clips.output.phones,
        clips=rules.corpus_clips.output.clips,
        regions=rules.corpus_clips.output.regions,
    output:
        targets=report(
            f"{VISEMES}/candidates.tsv",
            caption="../report/candidates.rst",
            category="Visemes",
        ),
        visemes=f"{VISEMES}/visemes.tsv",
        images=directory(f"{VISEMES}/images"),
        sheet=report(
            f"{VISEMES}/contact_sheet.png",
            caption="../report/contact_sheet.rst",
            category="Visemes",
        ),
    log:
        "results/logs/visemes/{face}.log",
    benchmark:
        "results/benchmarks/visemes/{face}.tsv"
    wildcard_constraints:
        face=one_of(CLIP_FACES),
    priority: CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        grouping=canonical(config["visemes"]["grouping"]),
    script:
        "../scripts/visemes_clips.py"
