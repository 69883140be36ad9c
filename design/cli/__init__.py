"""The ``bridgeflap`` command line: the command table and entry point (``main``), what every
command shares (``common``), help text (``help``), running one command and ending it
(``run``), and one module per command (``actuators``, ``buffeting``, ``derivatives``,
``erection``, ``imported``, ``optimise``, ``placement``, ``robustness``, ``section``,
``study``).

May import: everything (the top layer; nothing imports it).
"""
