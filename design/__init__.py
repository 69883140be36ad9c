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
