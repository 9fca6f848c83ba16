# miketalk: corpus -> visemes -> flows -> model -> utterances -> metrics -> figures -> report
from snakemake.utils import min_version

min_version("8.0")


configfile: "config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/corpus.smk"
include: "workflow/rules/visemes.smk"
include: "workflow/rules/flows.smk"
include: "workflow/rules/model.smk"
include: "workflow/rules/utterances.smk"
include: "workflow/rules/metrics.smk"
include: "workflow/rules/evaluation.smk"
include: "workflow/rules/figures.smk"


rule all:
    default_target: True
    input:
        targets.all_outputs(experiment),
