# Measurements against the synthetic face's truth (skipped for a person's recording).


rule morph_fidelity:
    input:
        visemes=paths.at(rules.visemes.output.visemes, experiment.truth),
        images=paths.at(rules.visemes.output.images, experiment.truth),
        flows=experiment.model_flows(experiment.truth),
        truth=rules.true_flows.output.flows,
        mouth=rules.true_flows.output.mouth,
        table=paths.at(rules.corpus.output.table, experiment.truth),
    output:
        table=report(
            paths.MORPH_FIDELITY_TABLE,
            caption="../report/morph_fidelity.rst",
            category="Morphing",
        ),
        summary=paths.MORPH_FIDELITY_SUMMARY,
    log:
        paths.log("morph_fidelity/{face}", face=experiment.truth),
    benchmark:
        paths.benchmark("morph_fidelity/{face}", face=experiment.truth)
    conda:
        "../envs/miketalk.yaml"
    params:
        alphas=config["metrics"]["alphas"],
        morph=canonical(config["morph"]),
    script:
        "../scripts/morph_fidelity.py"


rule sync:
    input:
        model=paths.at(rules.model.output[0], experiment.truth),
        mouth=rules.true_flows.output.mouth,
        video=paths.at(rules.utterance.output.video, experiment.truth),
        timeline=paths.at(rules.utterance.output.timeline, experiment.truth),
    output:
        paths.at(paths.SYNC, experiment.truth),
    log:
        paths.log("sync/{face}/{sentence}", face=experiment.truth),
    benchmark:
        paths.benchmark("sync/{face}/{sentence}", face=experiment.truth)
    conda:
        "../envs/miketalk.yaml"
    params:
        name=lambda wildcards: wildcards.sentence,
        morph=experiment.morph_options(experiment.truth),
        grouping=experiment.grouping,
    script:
        "../scripts/sync.py"


rule sync_sweep_point:
    input:
        model=paths.at(rules.model.output[0], experiment.truth),
        mouth=rules.true_flows.output.mouth,
        video=paths.at(rules.sweep_utterance.output.video, experiment.truth),
        timeline=paths.at(rules.sweep_utterance.output.timeline, experiment.truth),
    output:
        paths.at(paths.SYNC_SWEEP, experiment.truth),
    log:
        paths.log("sync_sweep/{face}/{sampling}/px{px}_fps{fps}", face=experiment.truth),
    benchmark:
        paths.benchmark(
            "sync_sweep/{face}/{sampling}/px{px}_fps{fps}", face=experiment.truth
        )
    wildcard_constraints:
        sampling=paths.one_of(vocabulary.SAMPLINGS),
        px=paths.NUMBER,
        fps=paths.NUMBER,
    conda:
        "../envs/miketalk.yaml"
    params:
        name=config["sweeps"]["sentence"],
        morph=experiment.morph_options(experiment.truth),
        grouping=experiment.grouping,
    script:
        "../scripts/sync.py"


rule sync_table:
    input:
        targets.sync_tables(experiment),
    output:
        table=report(
            paths.SYNC_TABLE, caption="../report/sync.rst", category="Lip-sync"
        ),
        summary=paths.SYNC_SUMMARY,
    log:
        paths.log("sync_table"),
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/sync_summary.py"


rule sync_sweep_table:
    input:
        targets.sync_sweep_tables(experiment),
    output:
        table=paths.SYNC_SWEEP_TABLE,
        summary=report(
            paths.SYNC_SWEEP_SUMMARY,
            caption="../report/sync_sweep.rst",
            category="Lip-sync",
        ),
    log:
        paths.log("sync_sweep_table"),
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/sync_summary.py"


rule truth_note:
    output:
        paths.TRUTH_SKIPPED,
    log:
        paths.log("truth_note"),
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/truth_note.py"
