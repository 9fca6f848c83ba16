# The workflow's settings come from miketalk_lab.workflow, a tested module that reads no
# Snakemake globals: the config checked against the schema (its defaults filled in) and
# every face's settings and files checked, before any job; the faces by kind, the sweeps,
# the rules' input functions and the default target; and every path pattern, in its paths.
# Here they are only built from Snakemake's config and the project directory.
from miketalk_lab.workflow import paths, targets, vocabulary
from miketalk_lab.workflow.config import canonical
from miketalk_lab.workflow.experiment import Experiment
from miketalk_lab.workflow.inputs import Inputs

#: The config, validated and checked, and all it derives.
experiment = Experiment.from_config(config, workflow.basedir)
#: The rules' functions of wildcards: input functions, per-job params and priorities.
inputs = Inputs(experiment)
