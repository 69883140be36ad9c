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
    "design": "design.assessment.accept", "accept": "design.assessment.accept",
    "AcceptanceResult": "design.assessment.accept",
    "DesignResult": "design.control.result",
    "local_sensitivity": "design.sensitivity.local",
    "global_sensitivity": "design.studies.screening",
    "load_study": "design.studies.study", "run_study": "design.studies.study",
    "study_from_dict": "design.studies.study",
    "load_doe": "design.studies.experiments", "run_doe": "design.studies.experiments",
    "doe_from_dict": "design.studies.experiments",
    "run_batch": "design.batch.runner",
    "open_run": "design.studies.runs", "RunRecord": "design.studies.runs",
    "make_design": "design.batch.designs",
    "main": "design.cli.main",
}
#: The flat modules before the rooms and where they went: importing one gives
#: a one-line ModuleNotFoundError naming its new home (model.lazy.moved_modules).
_MOVED = {
    "acceptance": "design.assessment.acceptance",
    "actuator_study": "design.assessment.actuator_study", "analyses": "design.studies.analyses",
    "batch_case": "design.batch.case", "batch_table": "design.batch.table",
    "branch_flags": "design.batch.branch_flags", "buffeting_term": "design.control.buffeting_term",
    "cases": "design.studies.cases", "checks": "design.control.checks",
    "cli_common": "design.cli.common", "cli_help": "design.cli.help", "cli_run": "design.cli.run",
    "cluster": "design.batch.cluster", "cmd_actuators": "design.cli.actuators",
    "cmd_buffeting": "design.cli.buffeting", "cmd_derivatives": "design.cli.derivatives",
    "cmd_erection": "design.cli.erection", "cmd_imported": "design.cli.imported",
    "cmd_optimise": "design.cli.optimise", "cmd_robustness": "design.cli.robustness",
    "cmd_section": "design.cli.section", "cmd_study": "design.cli.study",
    "critical_speed": "design.control.critical_speed", "cuts": "design.control.cuts",
    "designs": "design.batch.designs", "document": "design.studies.document",
    "doe": "design.batch.runner", "driver": "design.control.driver",
    "eigen": "design.control.eigen", "erection_control": "design.assessment.erection_control",
    "experiments": "design.studies.experiments", "failsafe": "design.assessment.failsafe",
    "figures": "design.control.figures, design.sensitivity.figures, design.studies.figures",
    "flap_count": "design.control.flap_count", "harm": "design.assessment.harm",
    "harm_fast": "design.assessment.harm_fast", "harm_verdict": "design.assessment.harm_verdict",
    "ift": "design.sensitivity.ift", "ipopt_hooks": "design.control.ipopt_hooks",
    "layout_search": "design.control.layout_search", "loop_algebra": "design.control.loop_algebra",
    "manifest": "design.io.manifest", "modal_sensitivity": "design.sensitivity.modal",
    "nlp": "design.control.nlp", "nlp_tolerances": "design.control.nlp_tolerances",
    "options": "design.io.options", "outputs": "design.io.outputs",
    "pair_failure": "design.control.pair_failure", "plant": "design.control.plant",
    "problem_model": "design.control.problem_model", "records": "design.control.records",
    "report": "design.studies.report", "result": "design.control.result",
    "result_plots": "design.control.result_plots", "robust": "design.control.robust",
    "screening": "design.studies.screening", "settings": "design.control.settings",
    "start": "design.control.start", "study": "design.studies.study",
    "uncertainty": "design.control.uncertainty", "variants": "design.control.variants",
    "verification": "design.control.verification",
}
from model.lazy import (  # noqa: E402 - after the tables they serve
    keep_public_names,
    moved_modules,
    public_face,
)

__all__, __getattr__, __dir__ = public_face("design", _PUBLIC)
keep_public_names(__name__)  # design.<function> is never shadowed by a submodule
moved_modules(__name__, _MOVED)  # import design.<old flat module>: where it went
