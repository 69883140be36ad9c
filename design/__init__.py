"""bridgeflap design layer: optimisation, sensitivity, batches, studies and the CLI.

Rooms, bottom to top (each imports only :mod:`bridgeflap.model` and the rooms below it;
tests/project/test_layering.py holds the rule):

- :mod:`bridgeflap.design.io`: reading options and definition files, atomic outputs, output folders,
  the run manifest.
- :mod:`bridgeflap.design.batch`: the fault-tolerant batch runner and sampling plans (no physics).
- :mod:`bridgeflap.design.control`: the compensator NLP, its driver, checks and result (in rooms
  of its own: results, formulation, review, solve, search).
- :mod:`bridgeflap.design.sensitivity`: implicit-function sensitivities and global screening.
- :mod:`bridgeflap.design.assessment`: do no harm, failed flaps, actuator limits, acceptance.
- :mod:`bridgeflap.design.studies`: the analyses registry, studies, DOE files, the report.
- :mod:`bridgeflap.design.cli`: the ``bridgeflap`` command line (entry point
  :func:`bridgeflap.design.cli.main.main`).

Importing this package imports nothing else: the public names below resolve on first use.
"""

#: What a script imports: ``from design import design, load_settings, run_study, ...``;
#: resolved on first use (PEP 562), so ``import design`` imports nothing heavy.
_PUBLIC = {
    "ANALYSES": "bridgeflap.design.studies.analyses",
    "DEFAULT_SPEEDS": "bridgeflap.design.studies.analyses",
    "parse_range": "bridgeflap.design.io.options",
    "DesignSettings": "bridgeflap.design.control.settings",
    "load_settings": "bridgeflap.design.control.settings",
    "quick_settings": "bridgeflap.design.control.settings",
    "design": "bridgeflap.design.assessment.accept",
    "accept": "bridgeflap.design.assessment.accept",
    "AcceptanceResult": "bridgeflap.design.assessment.accept",
    "do_no_harm": "bridgeflap.design.assessment.harm",
    "DesignResult": "bridgeflap.design.control.results.result",
    "placement_search": "bridgeflap.design.control.search.placement",
    "PlacementResult": "bridgeflap.design.control.results.placement",
    "local_sensitivity": "bridgeflap.design.sensitivity.local",
    "global_sensitivity": "bridgeflap.design.studies.screening",
    "load_study": "bridgeflap.design.studies.study", "run_study": "bridgeflap.design.studies.study",
    "study_from_dict": "bridgeflap.design.studies.study",
    "load_doe": "bridgeflap.design.studies.experiments",
    "run_doe": "bridgeflap.design.studies.experiments",
    "doe_from_dict": "bridgeflap.design.studies.experiments",
    "run_batch": "bridgeflap.design.batch.runner",
    "open_run": "bridgeflap.design.studies.runs", "RunRecord": "bridgeflap.design.studies.runs",
    "make_design": "bridgeflap.design.batch.designs",
    "main": "bridgeflap.design.cli.main",
}
#: The flat modules before the rooms and where they went: importing one gives
#: a one-line ModuleNotFoundError naming its new home (model.lazy.moved_modules).
_MOVED = {
    "acceptance": "bridgeflap.design.assessment.acceptance",
    "actuator_study": "bridgeflap.design.assessment.actuator_study",
    "analyses": "bridgeflap.design.studies.analyses",
    "batch_case": "bridgeflap.design.batch.case", "batch_table": "bridgeflap.design.batch.table",
    "branch_flags": "bridgeflap.design.batch.branch_flags",
    "buffeting_term": "bridgeflap.design.control.formulation.buffeting_term",
    "cases": "bridgeflap.design.studies.cases", "checks": "bridgeflap.design.control.review.checks",
    "cli_common": "bridgeflap.design.cli.common", "cli_help": "bridgeflap.design.cli.help",
    "cli_run": "bridgeflap.design.cli.run",
    "cluster": "bridgeflap.design.batch.cluster",
    "cmd_actuators": "bridgeflap.design.cli.actuators",
    "cmd_buffeting": "bridgeflap.design.cli.buffeting",
    "cmd_derivatives": "bridgeflap.design.cli.derivatives",
    "cmd_erection": "bridgeflap.design.cli.erection",
    "cmd_imported": "bridgeflap.design.cli.imported",
    "cmd_optimise": "bridgeflap.design.cli.optimise",
    "cmd_robustness": "bridgeflap.design.cli.robustness",
    "cmd_section": "bridgeflap.design.cli.section", "cmd_study": "bridgeflap.design.cli.study",
    "critical_speed": "bridgeflap.design.control.search.critical_speed",
    "cuts": "bridgeflap.design.control.formulation.cuts",
    "designs": "bridgeflap.design.batch.designs", "document": "bridgeflap.design.studies.document",
    "doe": "bridgeflap.design.batch.runner", "driver": "bridgeflap.design.control.search.driver",
    "eigen": "bridgeflap.design.control.formulation.eigen",
    "erection_control": "bridgeflap.design.assessment.erection_control",
    "experiments": "bridgeflap.design.studies.experiments",
    "failsafe": "bridgeflap.design.assessment.failsafe",
    "figures": "bridgeflap.design.control.results.figures, bridgeflap.design.sensitivity.figures, "
    "bridgeflap.design.studies.figures",
    "flap_count": "bridgeflap.design.control.review.flap_count",
    "harm": "bridgeflap.design.assessment.harm",
    "harm_fast": "bridgeflap.design.assessment.harm_fast",
    "harm_verdict": "bridgeflap.design.assessment.harm_verdict",
    "ift": "bridgeflap.design.sensitivity.ift",
    "ipopt_hooks": "bridgeflap.design.control.formulation.ipopt_hooks",
    "layout_search": "bridgeflap.design.control.search.layout_search",
    "loop_algebra": "bridgeflap.design.control.formulation.loop_algebra",
    "manifest": "bridgeflap.design.io.manifest",
    "modal_sensitivity": "bridgeflap.design.sensitivity.modal",
    "nlp": "bridgeflap.design.control.formulation.nlp",
    "nlp_tolerances": "bridgeflap.design.control.formulation.nlp_tolerances",
    "options": "bridgeflap.design.io.options", "outputs": "bridgeflap.design.io.outputs",
    "pair_failure": "bridgeflap.design.control.solve.pair_failure",
    "plant": "bridgeflap.design.control.formulation.plant",
    "problem_model": "bridgeflap.design.control.formulation.problem_model",
    "records": "bridgeflap.design.control.results.records",
    "report": "bridgeflap.design.studies.report",
    "result": "bridgeflap.design.control.results.result",
    "result_plots": "bridgeflap.design.control.results.result_plots",
    "robust": "bridgeflap.design.control.formulation.robust",
    "screening": "bridgeflap.design.studies.screening",
    "settings": "bridgeflap.design.control.settings",
    "start": "bridgeflap.design.control.solve.start", "study": "bridgeflap.design.studies.study",
    "uncertainty": "bridgeflap.design.control.uncertainty",
    "variants": "bridgeflap.design.control.formulation.variants",
    "verification": "bridgeflap.design.control.formulation.verification",
}
from bridgeflap.model.lazy import (  # noqa: E402 - after the tables they serve
    keep_public_names,
    moved_modules,
    public_face,
)

__all__, __getattr__, __dir__ = public_face(__name__, _PUBLIC)
keep_public_names(__name__)  # design.<function> is never shadowed by a submodule
moved_modules(__name__, _MOVED)  # import design.<old flat module>: where it went
