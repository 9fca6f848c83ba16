"""The Snakemake workflow's settings, as a tested module: ``workflow/rules/common.smk`` only
builds an :class:`~.experiment.Experiment` from Snakemake's ``config`` and the project directory.

- :mod:`.config`: the config checked against workflow/schemas/config.schema.yaml (its
  defaults filled in), a violation in one line; :func:`~.config.canonical` params;
- :mod:`.faces`: which faces are what kind (synthetic, one video, clips), the truth face;
- :mod:`.sweeps`: the training-clips, pyramid-depth and sync sweeps;
- :mod:`.checks`: what the schema cannot check (settings that go together, the clips' files);
- :mod:`.experiment`: :class:`~.experiment.Experiment`, the config and all it derives;
- :mod:`.paths`: every path pattern the rules use, in one place;
- :mod:`.inputs`: the rules' functions of wildcards (:class:`~.inputs.Inputs`);
- :mod:`.targets`: the default target and the lists of files the tables gather;
- :mod:`.vocabulary`: the lip-sync models, samplings and strategies, from the library.

Nothing here reads Snakemake's globals. The package imports none of its modules (they
import each other by their full names).
"""
