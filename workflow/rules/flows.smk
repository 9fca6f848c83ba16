# Flows between visemes (paper section 5.2): by method (estimator + settings) and strategy,
# ground truth from the synthetic face, and endpoint error against it.


rule flows:
    input:
        unpack(inputs.mixed_flows),
        unpack(inputs.clip_regions),
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        frames=rules.corpus.output.frames,
    output:
        flows=directory(paths.FLOW_DATABASE),
        choices=paths.FLOW_CHOICES,
    log:
        paths.log("flows/{face}/{method}/{strategy}"),
    benchmark:
        paths.benchmark("flows/{face}/{method}/{strategy}")
    wildcard_constraints:
        strategy=paths.one_of(vocabulary.STRATEGY_NAMES),
        face=paths.one_of(experiment.faces),
    priority: inputs.clip_chain_first
    conda:
        "../envs/miketalk.yaml"
    threads: config["flow"]["workers"]
    resources:
        mem_mb=6000,
        runtime=60,
    params:
        spec=inputs.method_spec,
        window=config["flow"]["mixed_window"],
    script:
        "../scripts/flows.py"


rule true_flows:
    input:
        visemes=paths.at(rules.visemes.output.visemes, experiment.truth),
        table=paths.at(rules.corpus.output.table, experiment.truth),
    output:
        flows=directory(paths.at(paths.TRUE_FLOWS, experiment.truth)),
        mouth=paths.at(paths.TRUE_MOUTH, experiment.truth),
    log:
        paths.log("true_flows/{face}", face=experiment.truth),
    benchmark:
        paths.benchmark("true_flows/{face}", face=experiment.truth)
    conda:
        "../envs/miketalk.yaml"
    params:
        size=experiment.truth_size,
    script:
        "../scripts/true_flows.py"


rule flow_epe:
    input:
        flows=paths.at(paths.FLOW_DATABASE, experiment.truth),
        truth=rules.true_flows.output.flows,
        mouth=rules.true_flows.output.mouth,
    output:
        paths.at(paths.EPE, experiment.truth),
    log:
        paths.log("flow_epe/{face}/{method}/{strategy}", face=experiment.truth),
    benchmark:
        paths.benchmark("flow_epe/{face}/{method}/{strategy}", face=experiment.truth)
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=inputs.method_spec,
    script:
        "../scripts/flow_epe.py"


rule flow_epe_table:
    input:
        targets.epe_tables(experiment),
    output:
        table=report(
            paths.EPE_TABLE,
            caption="../report/flow_epe.rst",
            category="Optical flow",
        ),
        summary=paths.EPE_SUMMARY,
    log:
        paths.log("flow_epe_table"),
    conda:
        "../envs/miketalk.yaml"
    script:
        "../scripts/concat_tables.py"


rule motorcycle:
    output:
        report(
            paths.MOTORCYCLE_EPE,
            caption="../report/motorcycle.rst",
            category="Optical flow",
        ),
    log:
        paths.log("motorcycle"),
    benchmark:
        paths.benchmark("motorcycle")
    conda:
        "../envs/miketalk.yaml"
    params:
        methods=canonical(config["flow"]["methods"]),
    script:
        "../scripts/motorcycle.py"
