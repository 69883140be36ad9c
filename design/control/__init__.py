"""The compensator design (the paper, section 6), in rooms by concept.

Rooms, bottom to top (each imports only the rooms below it and the layers below
:mod:`bridgeflap.design.control`; tests/project/test_layering.py holds the rule):

- the foundation, the top-level modules: the settings card (``settings``) and the stated
  uncertainty set of the estimated inputs (``uncertainty``);
- :mod:`bridgeflap.design.control.results`: a design's outcome as data and plots -- the records,
  :class:`~bridgeflap.design.control.results.result.DesignResult`, its figures and plots;
- :mod:`bridgeflap.design.control.formulation`: the design problem as an Ipopt NLP -- the
  problem's model and plant, the NLP with its tolerances, Ipopt hooks and cutting planes, the
  spectral-abscissa constraints, the robustness, buffeting and actuator-demand terms, the
  multi-model variants and the dense check of a solution;
- :mod:`bridgeflap.design.control.review`: checks and reports around a solved design -- the
  closed-loop limits, active constraints, fresh variants, the margin grid, buffeting and the
  flap count;
- :mod:`bridgeflap.design.control.solve`: one solve and what it is held to -- the scenario
  bridges, the one-pair-failed plants and one start of the multistart design;
- :mod:`bridgeflap.design.control.search`: the searches over solves -- the layout search, the
  critical-speed design and the multistart driver
  :func:`bridgeflap.design.control.search.driver.design`.

May import: :mod:`bridgeflap.model`, :mod:`bridgeflap.design.io` and :mod:`bridgeflap.design.batch`
(the foundation: nothing else; each room's own docstring says which rooms of control it may
import).
"""

#: The flat modules before the rooms and where they went: importing one gives
#: a one-line ModuleNotFoundError naming its new home (model.lazy.moved_modules).
_MOVED = {
    "actuator_demand": "bridgeflap.design.control.formulation.actuator_demand",
    "buffeting_term": "bridgeflap.design.control.formulation.buffeting_term",
    "checks": "bridgeflap.design.control.review.checks",
    "critical_speed": "bridgeflap.design.control.search.critical_speed",
    "cuts": "bridgeflap.design.control.formulation.cuts",
    "driver": "bridgeflap.design.control.search.driver",
    "eigen": "bridgeflap.design.control.formulation.eigen",
    "figures": "bridgeflap.design.control.results.figures",
    "flap_count": "bridgeflap.design.control.review.flap_count",
    "ipopt_hooks": "bridgeflap.design.control.formulation.ipopt_hooks",
    "layout_search": "bridgeflap.design.control.search.layout_search",
    "loop_algebra": "bridgeflap.design.control.formulation.loop_algebra",
    "nlp": "bridgeflap.design.control.formulation.nlp",
    "nlp_tolerances": "bridgeflap.design.control.formulation.nlp_tolerances",
    "pair_failure": "bridgeflap.design.control.solve.pair_failure",
    "plant": "bridgeflap.design.control.formulation.plant",
    "problem_model": "bridgeflap.design.control.formulation.problem_model",
    "records": "bridgeflap.design.control.results.records",
    "result": "bridgeflap.design.control.results.result",
    "result_plots": "bridgeflap.design.control.results.result_plots",
    "robust": "bridgeflap.design.control.formulation.robust",
    "scenarios": "bridgeflap.design.control.solve.scenarios",
    "spectral_terms": "bridgeflap.design.control.formulation.spectral_terms",
    "start": "bridgeflap.design.control.solve.start",
    "variants": "bridgeflap.design.control.formulation.variants",
    "verification": "bridgeflap.design.control.formulation.verification",
}

from bridgeflap.model.lazy import moved_modules  # noqa: E402 - after the table it serves

moved_modules(__name__, _MOVED)  # import design.control.<old flat module>: where it went
