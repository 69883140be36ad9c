"""design.studies: studies built on the registry of analyses, and the built-in study files.

Both a package of modules (the registry :mod:`design.studies.analyses`, the DOE case functions
:mod:`design.studies.cases`, study and DOE files :mod:`design.studies.study` and
:mod:`design.studies.experiments`, the global screening :mod:`design.studies.screening`, the
report and its Fig. 5) and the home of the built-in study definitions (``*.toml``), shipped as
package data (``[tool.setuptools.package-data]`` in pyproject.toml) and found with
``importlib.resources.files("design.studies")``. Importing it imports nothing else.
"""
