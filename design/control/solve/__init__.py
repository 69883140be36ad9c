"""One solve of the design and what it is held to: the scenario bridges of the stated
uncertainty set with their open-loop limits (``scenarios``), the one-pair-failed plants as
extra models (``pair_failure``), and one start of the multistart design -- its starting points
(the nominal one and screened Sobol points), the solve with cutting planes, the rounding of a
relaxed flap layout by whole groups and the re-solve on it, the record of a solved start, and
the choice among the starts (``start``).

May import: the foundation of :mod:`bridgeflap.design.control` (``settings``, ``uncertainty``),
:mod:`bridgeflap.design.control.results`, :mod:`bridgeflap.design.control.formulation`,
:mod:`bridgeflap.design.control.review`, :mod:`bridgeflap.model`, :mod:`bridgeflap.design.io` and
:mod:`bridgeflap.design.batch`.
"""
