"""bridgeflap design layer: analyses registry, studies, DOE batches, optimisation, CLI.

Module map (each file one job; importing this package imports nothing else):

- :mod:`design.studies.analyses`: the registry of analyses (runner, defaults, DOE case row) that the
  command line, studies and DOE cases share; the default speed grid and mode count.
- :mod:`design.io.options`: grid text (``start:stop:step``), definition files, option checks.
- :mod:`design.studies.study` / :mod:`design.studies.report`: study files and runner; ``report.md``,
  Fig. 5.
- :mod:`design.studies.experiments`: DOE files, run through the batch runner.
- :mod:`design.batch.designs` / :mod:`design.batch.runner` / :mod:`design.studies.cases`: sampling
  plans, the batch runner (no physics), picklable case functions.
- :mod:`design.io.files` / :mod:`design.io.manifest`: output folders, atomic files, run manifest.
- :mod:`design.cli.main` (entry point ``main``), :mod:`design.cli.common`, ``design.cmd_*``.
"""

#: What a script imports: ``from design import design, load_settings, run_study, ...``;
#: resolved on first use (PEP 562), so ``import design`` imports nothing heavy.
_PUBLIC = {
    "ANALYSES": "design.studies.analyses", "DEFAULT_SPEEDS": "design.studies.analyses",
    "parse_range": "design.io.options",
    "DesignSettings": "design.control.settings", "load_settings": "design.control.settings",
    "quick_settings": "design.control.settings",
    "design": "design.control.driver",
    "DesignResult": "design.control.result",
    "local_sensitivity": "design.sensitivity.local",
    "global_sensitivity": "design.studies.screening",
    "load_study": "design.studies.study", "run_study": "design.studies.study",
    "study_from_dict": "design.studies.study",
    "load_doe": "design.studies.experiments", "run_doe": "design.studies.experiments",
    "doe_from_dict": "design.studies.experiments",
    "run_batch": "design.batch.runner",
    "make_design": "design.batch.designs",
    "main": "design.cli.main",
}
from model.lazy import keep_public_names, public_face  # noqa: E402 - after the table it serves

__all__, __getattr__, __dir__ = public_face("design", _PUBLIC)
keep_public_names(__name__)  # design.<function> is never shadowed by a submodule
