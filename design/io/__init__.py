"""What a run reads and writes: grid text, definition files and option values (``options``),
atomic self-describing output files (``files``), output folders with their ownership marker,
run lock and crash recovery (``outputs``), the run manifest (``manifest``), the number and
grid text of outputs (``text``), a bridge's identity in records (``identity``), scratch folders
in the temp folder that no killed run leaves behind (``scratch``) and the checks at the door of
the design API, with the bounds the CLI shares (``api_args``).

May import: :mod:`bridgeflap.model` only (the bottom layer of :mod:`bridgeflap.design`).
"""
