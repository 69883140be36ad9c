"""Sensitivities of the flutter and divergence speeds: the implicit-function core (``ift``), local
sensitivities to bridge parameters (``local``) and to imported modal data (``modal``), global
screening (Morris, Sobol') over the stated uncertainty set (``screening``, ``uncertainty``).

May import: :mod:`model`, :mod:`design.io`, :mod:`design.batch` and :mod:`design.control`.
"""
