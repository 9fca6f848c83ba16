# Measurements against the synthetic face's truth (skipped for a person's recording).


rule morph_fidelity:
    input:
        visemes=at(rules.visemes.output.visemes, TRUTH_FACE or "none"),
        images=at(rules.visemes.output.images, TRUTH_FACE or "none"),
        flows=model_flows(SimpleNamespace(face=TRUTH_FACE or "none")),
        truth=rules.true_flows.output.flows,
        mouth=rules.true_flows.output.mouth,
        table=at(rules.corpus.output.table, TRUTH_FACE or "none"),
    output:
        table=report(
            f"{METRICS}/morph_fidelity.csv",
            caption="../report/morph_fidelity.rst",
            category="Morphing",
        ),
        summary=f"{METRICS}/morph_fidelity_summary.csv",
    log:
        f"results/logs/morph_fidelity/{TRUTH_FACE}.log",
    benchmark:
        f"results/benchmarks/morph_fidelity/{TRUTH_FACE}.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        alphas=config["metrics"]["alphas"],
        morph=canonical(config["morph"]),
    script:
        "../scripts/morph_fidelity.py"


rule sync:
    input:
        model=at(rules.model.output[0], TRUTH_FACE or "none"),
        mouth=rules.true_flows.output.mouth,
        video=at(rules.utterance.output.video, TRUTH_FACE or "none"),
        timeline=at(rules.utterance.output.timeline, TRUTH_FACE or "none"),
    output:
        f"{METRICS}/sync/{TRUTH_FACE}/{{sentence}}.csv",
    log:
        f"results/logs/sync/{TRUTH_FACE}/{{sentence}}.log",
    benchmark:
        f"results/benchmarks/sync/{TRUTH_FACE}/{{sentence}}.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        name=lambda wildcards: wildcards.sentence,
        morph=morph_options(TRUTH_FACE or "none"),
        grouping=canonical(config["visemes"]["grouping"]),
    script:
        "../scripts/sync.py"


rule sync_sweep_point:
    input:
        model=at(rules.model.output[0], TRUTH_FACE or "none"),
        mouth=rules.true_flows.output.mouth,
        video=at(rules.sweep_utterance.output.video, TRUTH_FACE or "none"),
        timeline=at(rules.sweep_utterance.output.timeline, TRUTH_FACE or "none"),
    output:
        f"{METRICS}/sync_sweep/{TRUTH_FACE}/{{sampling}}/px{{px}}_fps{{fps}}.csv",
    log:
        f"results/logs/sync_sweep/{TRUTH_FACE}/{{sampling}}/px{{px}}_fps{{fps}}.log",
    benchmark:
        f"results/benchmarks/sync_sweep/{TRUTH_FACE}/{{sampling}}/px{{px}}_fps{{fps}}.tsv"
    wildcard_constraints:
        sampling=one_of(SAMPLINGS),
        px=NUMBER,
        fps=NUMBER,
    conda:
        "../envs/miketalk.yaml"
    params:
        name=config["sweeps"]["sentence"],
        morph=morph_options(TRUTH_FACE or "none"),
        grouping=canonical(config["visemes"]["grouping"]),
    script:
        "../scripts/sync.py"


rule sync_table:
    input:
        sync_tables(),
    output:
        table=report(
            f"{METRICS}/sync.csv", caption="../report/sync.rst", category="Lip-sync"
        ),
        summary=f"{METRICS}/sync_summary.csv",
    log:
        "results/logs/sync_table.log",
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/sync_summary.py"


rule sync_sweep_table:
    input:
        sync_sweep_tables(),
    output:
        table=f"{METRICS}/sync_sweep.csv",
        summary=report(
            f"{METRICS}/sync_sweep_summary.csv",
            caption="../report/sync_sweep.rst",
            category="Lip-sync",
        ),
    log:
        "results/logs/sync_sweep_table.log",
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/sync_summary.py"


rule truth_note:
    output:
        f"{METRICS}/SKIPPED.txt",
    log:
        "results/logs/truth_note.log",
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/truth_note.py"
