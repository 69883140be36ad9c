"""The fault-tolerant batch runner, without physics: sampling plans (``designs``), the runner
(``runner``), one case (``case``), its Dask side (``cluster``), its tables (``table``), the
branch-switch flags of a row (``branch_flags``) and the plot of a batch's cases (``plots``).

May import: :mod:`bridgeflap.model` and :mod:`bridgeflap.design.io`.
"""
