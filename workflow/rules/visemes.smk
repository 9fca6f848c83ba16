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
            paths.VISEME_TARGETS,
            caption="../report/targets.rst",
            category="Visemes",
        ),
        visemes=paths.VISEME_TABLE,
        images=directory(paths.VISEME_IMAGES),
        sheet=report(
            paths.CONTACT_SHEET,
            caption="../report/contact_sheet.rst",
            category="Visemes",
        ),
        strip=report(
            paths.WORD_STRIP,
            caption="../report/word_strip.rst",
            category="Visemes",
        ),
    log:
        paths.log("visemes/{face}"),
    benchmark:
        paths.benchmark("visemes/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.corpus_word_faces),
    conda:
        "../envs/miketalk.yaml"
    params:
        grouping=experiment.grouping,
        frames_table=experiment.project_path(config["visemes"]["frames_table"]),
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
            paths.VISEME_CANDIDATES,
            caption="../report/candidates.rst",
            category="Visemes",
        ),
        visemes=paths.VISEME_TABLE,
        images=directory(paths.VISEME_IMAGES),
        sheet=report(
            paths.CONTACT_SHEET,
            caption="../report/contact_sheet.rst",
            category="Visemes",
        ),
    log:
        paths.log("visemes/{face}"),
    benchmark:
        paths.benchmark("visemes/{face}")
    wildcard_constraints:
        face=paths.one_of(experiment.clip_faces),
    priority: inputs.CLIP_CHAIN
    conda:
        "../envs/miketalk.yaml"
    params:
        grouping=experiment.grouping,
    script:
        "../scripts/visemes_clips.py"
