"""The compensator design (the paper, section 6): the settings card (``settings``), the design
problem's model (``problem_model``, ``plant``), the Ipopt NLP over K(s) and the flap layout
(``nlp``, ``nlp_tolerances``, ``ipopt_hooks``), its cutting planes (``cuts``), spectral-abscissa
constraints (``eigen``), the robustness, buffeting and actuator-demand terms (``robust``,
``loop_algebra``, ``buffeting_term``, ``actuator_demand``, ``spectral_terms``), the scenario
design over the uncertainty set and multi-model variants
(``scenarios``, ``variants``, ``pair_failure``), the dense check (``verification``), the layout
search (``layout_search``, ``flap_count``), the multistart driver (``driver``, ``start``), the
critical-speed design (``critical_speed``), the stated uncertainty set of the estimated inputs
(``uncertainty``), and the result with its records, checks and plots (``result``, ``records``,
``checks``, ``figures``, ``result_plots``).

May import: :mod:`bridgeflap.model`, :mod:`bridgeflap.design.io` and :mod:`bridgeflap.design.batch`.
"""
