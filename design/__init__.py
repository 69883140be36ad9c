"""bridgeflap design layer: analyses registry, studies, DOE batches, optimisation, CLI.

Module map (each file one job; importing this package imports nothing else):

- :mod:`design.analyses`: the registry of analyses (runner, defaults, DOE case row) that the
  command line, studies and DOE cases share; the default speed grid and mode count.
- :mod:`design.options`: grid text (``start:stop:step``), definition files, option checks.
- :mod:`design.study` / :mod:`design.report`: study files and runner; ``report.md``, Fig. 5.
- :mod:`design.experiments`: DOE files, run through the batch runner.
- :mod:`design.designs` / :mod:`design.doe` / :mod:`design.cases`: sampling plans, the batch
  runner (no physics), picklable case functions.
- :mod:`design.io` / :mod:`design.manifest`: output folders, atomic files, run manifest.
- :mod:`design.cli` (entry point ``main``), :mod:`design.cli_common`, ``design.cmd_*``.
"""

#: What a script imports: ``from design import design, load_settings, run_study, ...``;
#: resolved on first use (PEP 562), so ``import design`` imports nothing heavy.
_PUBLIC = {
    "ANALYSES": "design.analyses", "DEFAULT_SPEEDS": "design.analyses",
    "parse_range": "design.options",
    "DesignSettings": "design.settings", "load_settings": "design.settings",
    "quick_settings": "design.settings", "design": "design.driver",
    "DesignResult": "design.result",
    "local_sensitivity": "design.sensitivity", "global_sensitivity": "design.screening",
    "load_study": "design.study", "run_study": "design.study",
    "study_from_dict": "design.study",
    "load_doe": "design.experiments", "run_doe": "design.experiments",
    "doe_from_dict": "design.experiments",
    "run_batch": "design.doe", "make_design": "design.designs",
    "main": "design.cli",
}
from model.lazy import keep_public_names, public_face  # noqa: E402 - after the table it serves

__all__, __getattr__, __dir__ = public_face("design", _PUBLIC)
keep_public_names(__name__)  # design.<function> is never shadowed by a submodule
