"""Typed exceptions of bridgeflap.

Every user-facing error is a :class:`BridgeflapInputError` (bad input: the message names the
field and the reason, one line; :class:`BridgeflapTypeError` for an argument of the wrong type or
kind) or a :class:`BridgeflapError` (anything else the package refuses to do). The CLI turns
both into one line on stderr and exit status 2.
"""


class BridgeflapError(Exception):
    """Base class of all bridgeflap errors.

    Catch it to handle every error the package raises on purpose; bad input is its subclass
    :class:`BridgeflapInputError` (also a :class:`ValueError`), which names the field.

    Parameters
    ----------
    *args : object
        The message, as for :class:`Exception`.
    """


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

    def __reduce__(self):
        # rebuilt from (field, reason), not from its one-message args: a worker process's
        # refusal reaches the parent as the same error (a pool cannot unpickle it otherwise)
        return type(self), (self.field, self.reason)


class BridgeflapTypeError(BridgeflapInputError, TypeError):
    """An argument of the wrong type or kind (a path where a controller is expected, a number
    where a bridge is): one line naming the argument, what it must be and what it got.

    A :class:`BridgeflapInputError` (so every handler of bad input catches it) and a
    :class:`TypeError` (what Python raises for a wrong type).
    """


class BatchFailedError(BridgeflapError):
    """Every case of a batch (DOE, global sensitivity) failed: no usable result.

    The batch folder is complete (each case's record says why it failed) and kept for the
    diagnosis; the CLI says so in one line with exit status 1 (a result that is not usable),
    not 2 (the input was accepted). ``out_dir`` is that folder, ``first_error`` one case's
    reason.
    """

    def __init__(self, cases: int, out_dir, first_error: str):
        self.cases, self.out_dir, self.first_error = cases, out_dir, first_error
        super().__init__(f"all {cases} cases failed (first: {first_error}); per-case records "
                         f"in {out_dir}/cases")

    def __reduce__(self):
        return type(self), (self.cases, self.out_dir, self.first_error)


class BridgeflapWarning(UserWarning):
    """A result is given, but something the user should know about how it was reached (a
    controller judged on another bridge than it was designed on): the line the command line
    prints as ``bridgeflap: warning: ...``, raised with :func:`warnings.warn` by the API."""
