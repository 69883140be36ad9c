"""The same-K flap-count search of the compensator design (:func:`minimum_flap_count`).

The optimised K(s) is kept and every evenly spaced flap count is checked on the dense grid of
the verification model, refined from a coarse subset
(:func:`bridgeflap.design.control.formulation.plant.damping_check_refined`), with one modal solution
for all counts (only the closed loop and its sweep per count). Re-exported by
:mod:`bridgeflap.design.control.search.driver`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.formulation.nlp_tolerances import VIOLATION_TOL
from bridgeflap.design.control.results.records import FlapCountCheck, FlapCountSearch
from bridgeflap.design.control.settings import DesignSettings

#: The same-K search over every count stops after this many consecutive failing counts.
MISSES_TO_STOP = 3


def minimum_flap_count(settings: DesignSettings, theta, counts=None, modal=None,
                       spec=None, known=None, pool=None) -> FlapCountSearch:
    """Fewest evenly spaced flaps (around mid-span) still stable 0..U_max with the margin.

    The optimised ``theta`` is kept; each count is verified on the dense grid with the
    minimum damping ratio ``zeta_min`` on the verification model (``verification_modes``).
    Returns the records per count and the minimum. ``spec``: the bridge (default
    ``settings.bridge``). Counts: ``counts``, else ``min_flap_counts``, else (default) every
    count from ``flap_count`` down to 1, stopping after ``MISSES_TO_STOP`` consecutive
    failing counts (the same-K check is cheap: one dense sweep each, one modal solution).
    ``known``: ``{count: Verification}`` of ``theta`` on that evenly spaced layout and the
    verification model, already computed (the chosen start's check of its full layout): not
    recomputed. With ``settings.parallel`` two counts at a time run in two processes, the
    next count submitted as soon as one finishes (same rows and minimum as the serial
    search: the stopping rule is applied count by count, in order); ``pool``: an executor
    of two processes to use (not shut down here; default: one of its own).
    """
    counts = settings.min_flap_counts if counts is None else counts
    every = not counts
    if every:
        counts = tuple(range(settings.flap_count, 0, -1))
    if modal is None:           # one modal solution for every count (the layout changes only)
        from bridgeflap.model.structure.fe import assemble
        from bridgeflap.model.structure.loader import load_bridge
        from bridgeflap.model.structure.modes import solve

        spec = load_bridge(settings.bridge if spec is None else spec)
        modal = solve(assemble(spec))
    counts = [int(c) for c in counts if c <= settings.flap_count]
    theta = tuple(float(v) for v in theta)
    known = dict(known or {})
    workers = 2 if settings.parallel and len(counts) > 1 else 1
    rows = []
    best = None
    misses = 0
    own = pool is None and workers > 1
    if own:                     # the counts in two processes, in order
        from bridgeflap.model.workers import process_pool

        pool = process_pool(workers)
    elif workers == 1:
        pool = None
    pending = {}                # index -> future (at most `workers` in flight)

    def result(i):
        c = counts[i]
        if c in known:
            return _count_row(c, known[c])
        if pool is None:
            return _check_count(settings, c, modal, spec, theta)
        j = i                   # keep the workers busy: count i and the next ones in flight
        while len(pending) < workers and j < len(counts):
            if j not in pending and counts[j] not in known:
                pending[j] = pool.submit(_check_count, settings, counts[j], modal, spec,
                                         theta)
            j += 1
        return pending.pop(i).result()

    try:
        for i in range(len(counts)):
            if every and misses >= MISSES_TO_STOP:
                break           # fewer flaps, less authority: stop after a run of failures
            row = result(i)
            rows.append(row)
            if row.meets_margin:
                best = row.flap_count if best is None else min(best, row.flap_count)
            misses = 0 if row.meets_margin else misses + 1
    finally:
        for f in pending.values():
            f.cancel()
        if own:
            pool.shutdown()
    return FlapCountSearch(minimum=best, counts=tuple(rows), modes=settings.verification_modes)


def _count_row(count, ver) -> FlapCountCheck:
    """The flap-count record of a dense check ``ver`` (Verification)."""
    return FlapCountCheck(flap_count=int(count),
                          meets_margin=bool(ver.max_violation_1_s <= VIOLATION_TOL),
                          stable_everywhere=ver.stable_everywhere,
                          stable_to_m_s=ver.stable_to_m_s,
                          max_violation_1_s=ver.max_violation_1_s)


def _check_count(settings, count, modal, spec, theta) -> FlapCountCheck:
    """Dense same-K check of ``count`` evenly spaced flaps on the verification model."""
    from bridgeflap.design.control.formulation.problem_model import build_model

    _, model = build_model(settings, count, modal, n_modes=settings.verification_modes,
                           spec=spec)
    # on the refined subset of the dense grid
    # (design.control.formulation.plant.damping_check_refined): the same decisions at 2.5-6x fewer
    # eigen-solutions (default design, counts 25..8: 58-145 of 341 speeds, every row identical to
    # the dense check's)
    return _count_row(count, DesignProblem(replace(settings, optimise_placement=False), model,
                                           numeric=True).verify(np.asarray(theta), refined=True))
