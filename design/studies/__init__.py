"""Studies built on the registry of analyses, their reports, and the built-in study files.

A package of modules: the registry of analyses (``analyses``), the picklable case functions of
a batch (``cases``), study and DOE definition files and their runners (``study``,
``experiments``; ``study_files``: what one analysis writes into a study folder), the global
screening over the stated uncertainty (``screening``: a study run over the registry, like a
DOE), the report (``report``, ``document``) and its Fig. 5 (``figures``), and the reader of
finished run folders (``runs``: ``open_run``).
Also the home of the built-in study definitions (``*.toml``), shipped as package
data (``[tool.setuptools.package-data]`` in pyproject.toml) and found with
``importlib.resources.files("bridgeflap.design.studies")``. Importing it imports nothing else.

May import: :mod:`bridgeflap.model` and every design layer below it.
"""
