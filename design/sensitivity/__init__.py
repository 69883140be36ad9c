"""Sensitivities of the flutter and divergence speeds: the implicit-function core (``ift``), local
sensitivities to bridge parameters (``local``) and to imported modal data (``modal``), and the
Morris plot of a global screening (``figures``; the screening itself runs over the analyses
registry and so lives in :mod:`bridgeflap.design.studies.screening`).

May import: :mod:`bridgeflap.model`, :mod:`bridgeflap.design.io`, :mod:`bridgeflap.design.batch` and
:mod:`bridgeflap.design.control`.
"""
