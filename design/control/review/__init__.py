"""Checks and reports around a solved design: the closed-loop flutter and divergence limits and
mechanism, the constraints active at the optimum, the variants sampled over the stated
uncertainty set and the a posteriori check on fresh ones, the margin on a speed grid, the
buffeting comparison and the flap-count Pareto with K re-optimised per count (``checks``), and
the same-K minimum flap count on the verification model (``flap_count``).

May import: the foundation of :mod:`bridgeflap.design.control` (``settings``, ``uncertainty``),
:mod:`bridgeflap.design.control.results`, :mod:`bridgeflap.design.control.formulation`,
:mod:`bridgeflap.model`, :mod:`bridgeflap.design.io` and :mod:`bridgeflap.design.batch`.
"""
