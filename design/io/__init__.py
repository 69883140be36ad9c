"""What a run reads and writes: grid text, definition files and option values (``options``),
atomic self-describing output files (``files``), output folders with their ownership marker,
run lock and crash recovery (``outputs``), the run manifest (``manifest``), the number and
grid text of outputs (``text``) and a bridge's identity in records (``identity``).

May import: :mod:`model` only (the bottom layer of :mod:`design`).
"""
