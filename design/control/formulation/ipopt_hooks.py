"""Ipopt iteration hooks of the compensator NLP
(:meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.solve`).

:class:`IterationCallback` is CasADi's ``iteration_callback``: once per Ipopt iteration it
calls the progress function (the tqdm bars of
:func:`bridgeflap.design.control.search.driver.design`) and, for the phase-1 solve, stops Ipopt at
the first iterate that satisfies every constraint (the damping constraints backed off by
``FEASIBILITY_BACKOFF_1_S``): phase 1 only has to find a strictly feasible point, and its objective
(the regularisation alone) gives the free ``gamma_T`` no direction, so the iterations after the
first feasible one only polish a point phase 2 moves away from (default card, start 0: feasible at
iteration 16 of 77).

Interrupts. Python runs a signal handler only between bytecodes; inside Ipopt that is inside one
of CasADi's Python callbacks, where an exception raised by the handler (``KeyboardInterrupt``) is
caught by CasADi and the solve goes on (measured: 6 of 9 Ctrl-C/SIGTERM during ``bridgeflap
optimise`` were lost, and the run wrote another controller). :func:`signals_deferred` therefore
holds SIGINT and SIGTERM during a solve: the handler only records the signal, the iteration
callback asks Ipopt to stop at its next iteration, and when the solve returns the signal is
delivered to the handler that was installed before (a ``KeyboardInterrupt``, the CLI's exit
130/143, or the default action). A solve stopped that way is never taken as a design: the
exception leaves before its iterate is read.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading

import casadi as ca
import numpy as np

#: Divergence watchdog of a warm-started re-solve (:class:`IterationCallback`):
#: stop when the iterate's largest constraint violation (NLP units: ``EIG_SCALE`` x damping
#: measure [1/s], robust epigraph, gain) has stayed above ``DIVERGE_LEVEL`` for more than
#: ``DIVERGE_ITERATIONS`` iterations without halving over them. Measured on the default card
#: (this machine, casadi 3.8.2, numpy 2.4.6): start 1's round 1 stalled at a violation of
#: 29-30 from iteration 11 on and ran to its 150-iteration cap (33.5 s, gamma_T 175, dense
#: peak 25.9, worse than round 0's 6.5); the worst converging round seen (start 0, round 0)
#: was above 5 for 17 iterations while falling from 390 to 11. 0 iterations: off.
DIVERGE_LEVEL = 5.0
DIVERGE_ITERATIONS = 20

#: The signals held during a solve (:func:`signals_deferred`); each block appends its list.
_HELD: list[list[int]] = []
_DEFERRED = (signal.SIGINT, signal.SIGTERM)


def stop_requested() -> bool:
    """Whether a signal arrived during the innermost :func:`signals_deferred` block."""
    return bool(_HELD and _HELD[-1])


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT and SIGTERM during the block (a compiled solve) and deliver the first one
    received to the previous handler when the block ends (see the module docstring).

    Outside the main thread (where no handler can be set) the block runs unchanged."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []

    def hold(signum, frame):
        got.append(int(signum))

    # a signal the process ignores stays ignored (the solve goes on, as it would have)
    previous = {s: h for s in _DEFERRED if (h := signal.getsignal(s)) != signal.SIG_IGN}
    for s in previous:
        signal.signal(s, hold)
    _HELD.append(got)
    try:
        yield
    finally:
        _HELD.pop()
        for s, h in previous.items():
            signal.signal(s, h)
        if got:
            if _HELD:            # an enclosing block delivers it
                _HELD[-1].append(got[0])
            else:
                _deliver(got[0], previous[got[0]])


def _deliver(signum: int, handler) -> None:
    """Signal ``signum`` as ``handler`` (the one before the solve) would have taken it."""
    if callable(handler):
        handler(signum, None)
    elif handler == signal.SIG_IGN:
        return
    elif signum == signal.SIGINT:
        raise KeyboardInterrupt
    else:                                 # the default action (SIGTERM: end the process)
        os.kill(os.getpid(), signum)
    raise KeyboardInterrupt               # a handler that returned: the solve is not a design


class IterationCallback(ca.Callback):
    """Ipopt ``iteration_callback``: calls ``fun(iteration, objective, x)`` once per Ipopt
    iteration (``fun`` may be None) and asks Ipopt to stop (status ``User_Requested_Stop``)
    when ``ubg`` is given and the iterate's constraints satisfy ``g <= ubg``. CasADi passes
    the nlpsol outputs (x, f, g, lam_x, lam_g, lam_p); keep the object alive during the
    solve.

    Attributes
    ----------
    count : int
        Iterations seen.
    stopped_feasible : bool
        True once the callback stopped Ipopt at a feasible iterate.
    stopped_diverged : bool
        True once the callback stopped Ipopt because the watchdog fired (``watch``).
    violations : list of float
        Largest constraint violation of each iterate (only with ``watch``).

    ``watch = (lbg, ubg, level, iterations)``: the divergence watchdog of a warm-started
    re-solve -- stop when the iterate's largest violation ``max(lbg - g, g - ubg)`` has stayed
    above ``level`` for more than ``iterations`` consecutive iterations and is not below half
    its value ``iterations`` iterations before: stalled far outside the feasible set
    (:data:`DIVERGE_LEVEL`).
    """

    def __init__(self, name, nx, ng, fun=None, ubg=None, watch=None):
        ca.Callback.__init__(self)
        self._nx, self._ng, self._fun, self.count = int(nx), int(ng), fun, 0
        self._ubg = None if ubg is None else np.asarray(ubg, float).ravel()
        self.stopped_feasible = False
        self.stopped_diverged = False
        self.violations = []
        self._watch = None
        if watch is not None:
            lo, hi, level, its = watch
            self._watch = (np.asarray(lo, float).ravel(), np.asarray(hi, float).ravel(),
                           float(level), int(its))
        self._over = 0
        self.construct(name, {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = ca.nlpsol_out(i)
        if n == "f":
            return ca.Sparsity.scalar()
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self._nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self._ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        if stop_requested():      # Ctrl-C or SIGTERM during the solve: stop Ipopt now
            return [1]
        if self._fun is not None:
            self._fun(self.count, float(arg[1]), np.asarray(arg[0]).ravel())
        self.count += 1
        if self._watch is not None:
            lo, hi, level, its = self._watch
            g = np.asarray(arg[2]).ravel()
            v = float(np.max(np.maximum(lo - g, g - hi), initial=0.0)) \
                if np.all(np.isfinite(g)) else np.inf
            self.violations.append(v)
            self._over = self._over + 1 if v > level else 0
            # stalled far outside: above `level` for `its` iterations and not halved over them
            if self._over > its and v > 0.5 * self.violations[-1 - its]:
                self.stopped_diverged = True
                return [1]
        if self._ubg is not None and self.count > 1:    # iteration 0 is the start point
            g = np.asarray(arg[2]).ravel()
            if np.all(np.isfinite(g)) and np.all(g <= self._ubg):
                self.stopped_feasible = True
                return [1]
        return [0]
