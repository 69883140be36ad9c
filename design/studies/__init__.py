"""Studies and their reports: the registry of analyses (``analyses``), the picklable case
functions of a batch (``cases``), study and DOE definition files and their runners (``study``,
``experiments``), the report (``report``, ``document``) and its figures (``figures``); the
packaged study and design cards (``*.toml``, package data) live here too.

May import: :mod:`model` and every design layer below it.
"""
