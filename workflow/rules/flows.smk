# Flows between visemes (paper section 5.2): by method (estimator + settings) and strategy,
# ground truth from the synthetic face, and endpoint error against it.


rule flows:
    input:
        unpack(mixed_flows),
        unpack(clip_regions),
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        frames=rules.corpus.output.frames,
    output:
        flows=directory(f"{FLOWS}/{{method}}/{{strategy}}"),
        choices=f"{FLOWS}/{{method}}/{{strategy}}.tsv",
    log:
        "results/logs/flows/{face}/{method}/{strategy}.log",
    benchmark:
        "results/benchmarks/flows/{face}/{method}/{strategy}.tsv"
    wildcard_constraints:
        strategy="|".join(STRATEGIES),
        face=one_of(FACES),
    priority: clip_chain_first
    conda:
        "../envs/miketalk.yaml"
    threads: config["flow"]["workers"]
    resources:
        mem_mb=6000,
        runtime=60,
    params:
        spec=method_spec,
        window=config["flow"]["mixed_window"],
    script:
        "../scripts/flows.py"


rule true_flows:
    input:
        visemes=at(rules.visemes.output.visemes, TRUTH_FACE or "none"),
        table=at(rules.corpus.output.table, TRUTH_FACE or "none"),
    output:
        flows=directory(f"{TRUTH}/flows"),
        mouth=f"{TRUTH}/mouth_mask.png",
    log:
        f"results/logs/true_flows/{TRUTH_FACE}.log",
    benchmark:
        f"results/benchmarks/true_flows/{TRUTH_FACE}.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        size=FACES[TRUTH_FACE]["corpus"]["size"] if TRUTH_FACE else None,
    script:
        "../scripts/true_flows.py"


rule flow_epe:
    input:
        flows=f"{at(FLOWS, TRUTH_FACE or 'none')}/{{method}}/{{strategy}}",
        truth=rules.true_flows.output.flows,
        mouth=rules.true_flows.output.mouth,
    output:
        f"{METRICS}/epe/{TRUTH_FACE}/{{method}}/{{strategy}}.csv",
    log:
        f"results/logs/flow_epe/{TRUTH_FACE}/{{method}}/{{strategy}}.log",
    benchmark:
        f"results/benchmarks/flow_epe/{TRUTH_FACE}/{{method}}/{{strategy}}.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=method_spec,
    script:
        "../scripts/flow_epe.py"


rule flow_epe_table:
    input:
        epe_tables(),
    output:
        table=report(
            f"{METRICS}/flow_epe.csv",
            caption="../report/flow_epe.rst",
            category="Optical flow",
        ),
        summary=f"{METRICS}/flow_epe_summary.csv",
    log:
        "results/logs/flow_epe_table.log",
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/concat_tables.py"


rule motorcycle:
    output:
        report(
            f"{METRICS}/motorcycle_epe.csv",
            caption="../report/motorcycle.rst",
            category="Optical flow",
        ),
    log:
        "results/logs/motorcycle.log",
    benchmark:
        "results/benchmarks/motorcycle.tsv"
    conda:
        "../envs/miketalk.yaml"
    params:
        methods=canonical(config["flow"]["methods"]),
    script:
        "../scripts/motorcycle.py"
