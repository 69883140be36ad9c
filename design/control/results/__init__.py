"""The outcome of a compensator design as data: one frozen record per result, units in field
names, each its part of the ``bridgeflap optimise --json`` contract (``records``), the design's
:class:`~bridgeflap.design.control.results.result.DesignResult` with its JSON summary
(``result``), its figures -- Bode plot, margins per speed, flap layout on the deck
(``figures``) -- the plots of the results that have no figure of their own
(``result_plots``), and the flap placement search's rows and result (``placement``). Plain
data and plots: the formulation and the searches above fill these records in.

May import: the foundation of :mod:`bridgeflap.design.control` (``settings``, ``uncertainty``),
:mod:`bridgeflap.model`, :mod:`bridgeflap.design.io` and :mod:`bridgeflap.design.batch`.
"""
