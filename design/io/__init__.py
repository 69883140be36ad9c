"""What a run reads and writes: grid text, definition files and option values (``options``),
atomic self-describing output files (``files``), output folders with their ownership marker,
run lock and crash recovery (``outputs``), and the run manifest (``manifest``).

May import: :mod:`model` only (the bottom layer of :mod:`design`).
"""
