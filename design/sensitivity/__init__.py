"""Sensitivities of the flutter and divergence speeds: the implicit-function core (``ift``), local
sensitivities to bridge parameters (``local``) and to imported modal data (``modal``), and the
Morris plot of a global screening (``figures``; the screening itself runs over the analyses
registry and so lives in :mod:`design.studies.screening`).

May import: :mod:`model`, :mod:`design.io`, :mod:`design.batch` and :mod:`design.control`.
"""
