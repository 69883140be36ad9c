"""The searches over solves, the top of :mod:`bridgeflap.design.control`: the rounded flap
layout against its neighbouring layouts (``layout_search``), the fewest flap strips that meet a
target speed with K(s) re-optimised per layout (``placement``), the critical-speed design, an outer
search over the design speed (``critical_speed``), and the multistart driver that runs the
starts, selects one, checks it and runs these searches when the card asks for them
(``driver``; its :func:`~bridgeflap.design.control.search.driver.design` is the compensator
design).

May import: the foundation of :mod:`bridgeflap.design.control` (``settings``, ``uncertainty``),
:mod:`bridgeflap.design.control.results`, :mod:`bridgeflap.design.control.formulation`,
:mod:`bridgeflap.design.control.review`, :mod:`bridgeflap.design.control.solve`,
:mod:`bridgeflap.model`, :mod:`bridgeflap.design.io` and :mod:`bridgeflap.design.batch`.
"""
