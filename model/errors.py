"""Typed exceptions of bridgeflap.

Every user-facing error is a :class:`BridgeflapInputError` (bad input: the message names the
field and the reason, one line) or a :class:`BridgeflapError` (anything else the package
refuses to do). The CLI turns both into one line on stderr and exit status 2.
"""


class BridgeflapError(Exception):
    """Base class of all bridgeflap errors."""


class BridgeflapInputError(BridgeflapError, ValueError):
    """Malformed, missing or physically impossible input.

    Parameters
    ----------
    field : str
        Name of the offending field (e.g. ``"deck.mass_kg_per_m"``).
    reason : str
        Why it is rejected, one line.
    """

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")
