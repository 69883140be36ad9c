"""Elapsed time and an estimate of the time left, for the progress lines of the long loops.

Every loop of counted steps that can run for more than a few seconds (the do-no-harm variants,
the design's Ipopt starts and iterations, erection stages, local sensitivities) says how far it
is with :class:`Eta`: ``do no harm: 20/50 variants (1 min 05 s elapsed, about 1 min 38 s
left)``. The time left is the rate so far times the steps left -- an estimate that assumes the
remaining steps cost what the finished ones did (a cap on the count, like Ipopt's iteration
cap, makes it an upper bound). The clock is injected so that the arithmetic is tested without
waiting (tests/project/test_progress_eta.py).

May import: the standard library only (a foundation module of :mod:`bridgeflap.model`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

__all__ = ["Eta", "counted", "duration_text"]


def duration_text(seconds: float) -> str:
    """``"42 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``; ``"?"`` when not finite or negative."""
    if seconds is None or not math.isfinite(seconds) or seconds < 0:
        return "?"
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class Eta:
    """Elapsed time and the time left of ``total`` steps, from the rate so far.

    Parameters
    ----------
    total : int
        Steps of the loop (a cap: the estimate is then an upper bound).
    clock : callable
        Seconds, monotonic (default :func:`time.monotonic`); the tests pass a fake one.

    The clock starts at construction; :meth:`text` after ``done`` steps gives the suffix of a
    progress line.
    """

    def __init__(self, total: int, clock: Callable[[], float] = time.monotonic):
        self.total = max(0, int(total))
        self.clock = clock
        self.t0 = clock()

    def elapsed_s(self) -> float:
        """Seconds since construction."""
        return self.clock() - self.t0

    def remaining_s(self, done: int) -> float:
        """``elapsed / done * (total - done)`` [s]; NaN before the first step, 0 at the end."""
        done = int(done)
        if done >= self.total:
            return 0.0
        if done <= 0:
            return math.nan
        return self.elapsed_s() / done * (self.total - done)

    def text(self, done: int) -> str:
        """``"(1 min 05 s elapsed, about 1 min 38 s left)"``; before the first step only the
        elapsed time, at the end ``"(2 min 43 s)"``."""
        elapsed = duration_text(self.elapsed_s())
        if int(done) >= self.total:
            return f"({elapsed})"
        left = self.remaining_s(done)
        if not math.isfinite(left):
            return f"({elapsed} elapsed)"
        return f"({elapsed} elapsed, about {duration_text(left)} left)"


def counted(total: int, say: Callable[[str], None], what: Callable[[object, int], str],
            clock: Callable[[], float] = time.monotonic) -> Callable[[object], None]:
    """A per-step progress callback: each call (with the step's own argument, e.g. an erected
    fraction or a parameter name) says ``what(arg, done)`` and the :class:`Eta` suffix, with
    ``done`` counted from 1. ``total`` steps."""
    eta, done = Eta(total, clock), [0]

    def step(arg=None):
        done[0] += 1
        say(f"{what(arg, done[0])} {eta.text(done[0])}")

    return step
