"""bridgeflap design layer: optimisation, sensitivity, batches, studies and the CLI.

Rooms, bottom to top (each imports only :mod:`model` and the rooms below it;
tests/project/test_layering.py holds the rule):

- :mod:`design.io`: reading options and definition files, atomic outputs, output folders,
  the run manifest.
- :mod:`design.batch`: the fault-tolerant batch runner and sampling plans (no physics).
- :mod:`design.control`: the compensator NLP, its driver, checks and result.
- :mod:`design.sensitivity`: implicit-function sensitivities and global screening.
- :mod:`design.assessment`: do no harm, failed flaps, actuator limits, acceptance.
- :mod:`design.studies`: the analyses registry, studies, DOE files, the report.
- :mod:`design.cli`: the ``bridgeflap`` command line (entry point :func:`design.cli.main.main`).

Importing this package imports nothing else: the public names below resolve on first use.
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
