"""The bridge as a structure: its definition (``spec``), reading it (``loader``, with the
built-in bridges' files in ``builtin_bridges``), writing it back (``bridge_toml`` the text,
``spec_writer`` the file), plausible input ranges (``limits``), lumped deck sections
(``section_props``), the ``bridge`` argument every function takes (``bridge_arg``), Irvine
cable statics with partial erection (``cable``), the FE deck hung from the cables (``fe``),
modes (``mode`` one mode, ``modes`` the solution), span and tower positions (``spans``), the
Ritz projection (``ritz``), imported modal models (``modal_files``, ``modal_model``,
``modal_import``) and the mode-shape figures (``plots``).

May import: the foundation of :mod:`bridgeflap.model` and :mod:`bridgeflap.model.aero` (an imported
modal bridge carries its flutter-derivative tables and static coefficients).
"""
