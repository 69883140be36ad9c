"""Built-in reference cases, used by the tests, the CLI and the benchmarks: the rigid 2-DOF
section (``section``), the IABSE TG3.1 section cases with flutter derivatives
(``section_cases``), the flat-plate cases on which an RFA is checked (``rfa_cases``) and the
measured Humber natural frequencies (``validation``).

May import: all of :mod:`bridgeflap.model` (it is the top layer of the physics).
"""
