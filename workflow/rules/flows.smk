# Flows between visemes (paper section 5.2): by method (estimator + settings) and strategy,
# ground truth from the synthetic face, and endpoint error against it.


rule flows:
    input:
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        frames=rules.corpus.output.frames,
    output:
        flows=directory(f"{FLOWS}/{{method}}/{{strategy}}"),
        choices=f"{FLOWS}/{{method}}/{{strategy}}.tsv",
    wildcard_constraints:
        strategy="direct|concat|mixed",
    params:
        spec=method_spec,
        window=config["flow"]["mixed_window"],
    threads: config["flow"]["workers"]
    log:
        f"logs/flows/{FACE}/{{method}}/{{strategy}}.log",
    benchmark:
        f"benchmarks/flows/{FACE}/{{method}}/{{strategy}}.tsv"
    resources:
        mem_mb=6000,
        runtime=60,
    script:
        "../scripts/flows.py"


rule true_flows:
    input:
        visemes=rules.visemes.output.visemes,
        table=rules.corpus.output.table,
    output:
        flows=directory(f"results/truth/{FACE}/flows"),
        mouth=f"results/truth/{FACE}/mouth_mask.png",
    params:
        size=config["corpus"]["size"],
    log:
        f"logs/true_flows/{FACE}.log",
    benchmark:
        f"benchmarks/true_flows/{FACE}.tsv"
    script:
        "../scripts/true_flows.py"


rule flow_epe:
    input:
        flows=f"{FLOWS}/{{method}}/{{strategy}}",
        truth=rules.true_flows.output.flows,
        mouth=rules.true_flows.output.mouth,
    output:
        f"{METRICS}/epe/{FACE}/{{method}}/{{strategy}}.csv",
    params:
        spec=method_spec,
    log:
        f"logs/flow_epe/{FACE}/{{method}}/{{strategy}}.log",
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
        "logs/flow_epe_table.log",
    script:
        "../scripts/concat_tables.py"


rule motorcycle:
    output:
        report(
            f"{METRICS}/motorcycle_epe.csv",
            caption="../report/motorcycle.rst",
            category="Optical flow",
        ),
    params:
        methods={name: spec for name, spec in config["flow"]["methods"].items()},
    log:
        "logs/motorcycle.log",
    benchmark:
        "benchmarks/motorcycle.tsv"
    script:
        "../scripts/motorcycle.py"
