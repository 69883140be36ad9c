"""The design problem as an Ipopt NLP (the paper, section 6): the problem's bridge and
closed-loop flap model with the warm start (``problem_model``), the flap-loop plant and
closed-loop eigenvalue checks in the NLP's data layout (``plant``), the NLP over K(s) and the
flap layout (``nlp``) with its scales and tolerances (``nlp_tolerances``), its Ipopt iteration
hooks (``ipopt_hooks``) and its cutting-plane loop (``cuts``), the differentiable
spectral-abscissa constraints (``eigen``), the robustness, buffeting and actuator-demand terms
(``robust``, ``loop_algebra``, ``buffeting_term``, ``actuator_demand``, ``spectral_terms``), the
lazily generated damping constraints of bridge variants (``variants``) and the dense
a posteriori check of a solution (``verification``).

May import: the foundation of :mod:`bridgeflap.design.control` (``settings``, ``uncertainty``),
:mod:`bridgeflap.design.control.results`, :mod:`bridgeflap.model`, :mod:`bridgeflap.design.io`
and :mod:`bridgeflap.design.batch`.
"""
