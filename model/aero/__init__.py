"""Aerodynamics of a deck section, with no bridge in sight: Theodorsen's and Sears' functions
and the flap T-functions (``theodorsen``), rational approximations of C(k) (``rfa``), the strip
loads of deck and flaps written once (``strips``) on the structural coordinates that carry them
(``basis``), flutter derivatives (``derivatives``), quasi-steady buffeting loads
(``quasi_steady``), turbulence spectra, coherence and admittance (``wind``, ``gust``) and
turbulence time series (``turbulence``).

May import: the foundation of :mod:`bridgeflap.model` (``bridgeflap.model.errors``,
``bridgeflap.model.grid`` ...) only.
"""
