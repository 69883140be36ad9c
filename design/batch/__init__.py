"""The fault-tolerant batch runner, without physics: sampling plans (``designs``), the runner
(``runner``), one case (``case``), its Dask side (``cluster``), its tables (``table``) and the
branch-switch flags of a row (``branch_flags``).

May import: :mod:`model` and :mod:`design.io`.
"""
