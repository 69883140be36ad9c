"""Flap layout: rounding of relaxed weights, and the rounded layout against its neighbours.

With ``optimise_placement`` the relaxed weights ``w = S z`` (one ``z`` per mirror pair with
``symmetric_layout``) choose the layout by rounding (:func:`round_layout`), then K(s) is
re-optimised on the rounded layout
(:func:`bridgeflap.design.control.solve.start.solve_fixed_layout`). Rounding at 0.5 is a heuristic;
this module measures how far it is from the neighbouring integer layouts.
:func:`compare_layouts` answers that at re-optimised K: every layout one group flip away
(a mirror pair, or the centre flap, added or removed; :func:`neighbour_layouts`) and the
contiguous centred blocks of about the same size are re-optimised and verified by
:func:`bridgeflap.design.control.solve.start.layout_record` -- the very machinery
:func:`bridgeflap.design.control.solve.start.run_start` applies to the rounded layout -- and ranked
by the design's selection criterion (:func:`bridgeflap.design.control.solve.start.select_start`: the
dense robust margin among verified layouts).

Every row carries its status; a layout whose solve fails is a row (``failed: ...``), never
dropped. ``bridgeflap optimise`` runs it on the chosen design with ``layout_neighbours =
true`` on the card (JSON key ``layout_neighbours``); ``layout_adopt = true`` then takes the
best verified neighbour when it beats the rounded layout (one local-search step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.design.control.solve.start import round_layout  # noqa: F401 - also served from here
from bridgeflap.model.results import strict_json

NAN = float("nan")
#: Positions equal within this [m] are the same candidate (candidates are ~56 m apart).
POSITION_TOL_M = 1e-6


def layout_groups(candidates, symmetric=True) -> np.ndarray:
    """Group matrix ``S`` (n_candidates, n_groups), innermost group first.

    With ``symmetric`` each mirror pair ``(x, -x)`` of the candidate positions [m] (and the
    centre flap of an odd count) is one group, as
    :attr:`bridgeflap.design.control.formulation.nlp.DesignProblem.symmetry` pairs them; otherwise
    every candidate is its own group. Columns are sorted by ``|x|``.
    """
    x = np.asarray(candidates, float)
    n = x.size
    order = np.argsort(x, kind="stable")
    if symmetric and np.allclose(x[order], -x[order][::-1], atol=POSITION_TOL_M):
        S = np.zeros((n, (n + 1) // 2))
        for r, i in enumerate(order):
            S[i, min(r, n - 1 - r)] = 1.0
    else:
        S = np.eye(n)
    radius = np.array([np.abs(x[S[:, j] > 0.5]).min() for j in range(S.shape[1])])
    return S[:, np.argsort(-radius, kind="stable")[::-1]]


def layout_mask(candidates, positions) -> np.ndarray:
    """0/1 vector over ``candidates`` [m] of the flaps at ``positions`` [m].

    Raises ``BridgeflapInputError`` when a position is not a candidate."""
    from bridgeflap.model.errors import BridgeflapInputError

    c = np.asarray(candidates, float)
    mask = np.zeros(c.size)
    for p in np.asarray(positions, float).ravel():
        j = int(np.argmin(np.abs(c - p)))
        if abs(c[j] - p) > POSITION_TOL_M:
            raise BridgeflapInputError("layout", f"flap at {p:g} m is not a candidate position "
                                                 "of the card (settings.positions())")
        mask[j] = 1.0
    return mask


def neighbour_layouts(candidates, positions, symmetric=True, blocks=1) -> list[dict]:
    """The rounded layout and its neighbouring integer layouts, innermost change first.

    Parameters
    ----------
    candidates : array_like
        Candidate flap centres [m] (``DesignSettings.positions()``).
    positions : array_like
        The rounded layout's flap centres [m].
    symmetric : bool
        Mirror pairs are groups (``symmetric_layout``).
    blocks : int
        Contiguous centred blocks of ``g - blocks .. g + blocks`` groups, ``g`` the rounded
        layout's group count (-1: none).

    Returns
    -------
    list of dict
        ``kind`` ("rounded", "add", "remove", "block"), ``mask`` over the candidates,
        ``group`` (index of the flipped group, innermost 0; None for blocks and the rounded
        layout), ``group_radius_m`` (its ``|x|``). The first entry is the rounded layout;
        then one flip of each group (so ``n_groups`` rows); then the blocks that are not
        already listed (a block equal to a flip keeps the flip's row, kind ``"add+block"``).
    """
    S = layout_groups(candidates, symmetric)
    x = np.abs(np.asarray(candidates, float))
    mask = layout_mask(candidates, positions)
    on = S.T @ mask
    if not np.all((on < 0.5) | (np.abs(on - S.sum(axis=0)) < 0.5)):
        from bridgeflap.model.errors import BridgeflapInputError

        raise BridgeflapInputError("layout", "the layout splits a mirror pair "
                                             "(symmetric_layout = true needs whole pairs)")
    z = (on > 0.5).astype(float)
    radius = [float(x[S[:, j] > 0.5].min()) for j in range(S.shape[1])]
    rows = [{"kind": "rounded", "mask": mask, "group": None, "group_radius_m": NAN}]
    for j in range(S.shape[1]):
        zj = z.copy()
        zj[j] = 1.0 - zj[j]
        if not zj.any():
            continue            # removing the only group leaves no flap: not a layout
        rows.append({"kind": "remove" if z[j] else "add", "mask": S @ zj, "group": j,
                     "group_radius_m": radius[j]})
    g = int(z.sum())
    for k in range(g - blocks, g + blocks + 1) if blocks >= 0 else ():
        if not 1 <= k <= S.shape[1]:
            continue
        m = S @ (np.arange(S.shape[1]) < k).astype(float)
        same = [r for r in rows if np.array_equal(r["mask"], m)]
        if same:
            if same[0]["kind"] != "rounded" and "block" not in same[0]["kind"]:
                same[0]["kind"] += "+block"
            continue
        rows.append({"kind": "block", "mask": m, "group": None, "group_radius_m": NAN})
    return rows


@dataclass(frozen=True)
class LayoutRow:
    """One layout of :func:`compare_layouts` with its re-optimised K(s).

    ``record`` is the :class:`bridgeflap.design.control.results.records.StartRecord` of
    :func:`bridgeflap.design.control.solve.start.layout_record` (or the design's own for the rounded
    layout); ``weight_relaxed`` [-] the relaxed weight ``z`` of the flipped group (NaN: not known or
    not a flip); ``gap_pct`` [%] the robust margin's difference to the rounded layout's,
    relative to it.
    """

    kind: str
    group: int | None
    group_radius_m: float
    weight_relaxed: float
    record: object
    gap_pct: float = NAN
    rank: int | None = None

    @strict_json
    def to_dict(self) -> dict:
        """One entry of ``layout_neighbours.rows``."""
        r = self.record
        ver = r.verification
        pos = sorted(float(p) for p in r.flap_positions_m)
        return {"kind": self.kind, "flap_count": len(pos), "flap_positions_m": pos,
                "changed_group": self.group, "changed_radius_m": self.group_radius_m,
                "weight_relaxed": self.weight_relaxed, "status": r.ipopt_status,
                "verified": bool(r.verified), "robust_margin": r.robust_margin,
                "gap_to_rounded_pct": self.gap_pct,
                "stable_to_m_s": r.stable_to_m_s,
                "verification_stable_to_m_s": ver.stable_to_m_s if ver is not None else NAN,
                "verification_modes": ver.modes if ver is not None else None,
                "max_gain": r.max_gain, "meets_damping": bool(r.meets_damping),
                "nlp_objective": r.nlp_objective,
                "gamma_T_frobenius": r.gamma_T_frobenius,
                "theta": list(r.theta) if r.theta is not None else None,
                "theta0": list(r.theta0), "iterations": r.iterations, "time_s": r.time_s,
                "rank": self.rank}


@dataclass(frozen=True)
class LayoutComparison:
    """The rounded layout against its neighbours (:func:`compare_layouts`).

    ``status``: ``ok`` (the rounded layout and at least one neighbour verified), ``no_
    neighbour_verified``, ``rounded_not_verified`` or ``none_verified``. ``best`` the index
    in ``rows`` of the best verified layout (largest robust margin; None when none verified);
    ``best_layout_is_rounded`` whether that is the rounded layout (no verified neighbour has
    a larger margin); ``best_neighbour_gap_pct`` [%] the best verified neighbour's margin
    relative to the rounded layout's (> 0: the neighbour is better).
    """

    status: str
    rows: tuple
    best: int | None
    best_layout_is_rounded: bool | None
    best_neighbour_gap_pct: float
    start: str
    time_s: float
    adopted: bool = False

    @property
    def best_record(self):
        """The best verified layout's record (None when none verified)."""
        return None if self.best is None else self.rows[self.best].record

    @strict_json
    def to_dict(self) -> dict:
        """The ``layout_neighbours`` JSON object."""
        return {"status": self.status, "best_row": self.best,
                "best_layout_is_rounded": self.best_layout_is_rounded,
                "best_neighbour_gap_pct": self.best_neighbour_gap_pct,
                "adopted": self.adopted,
                "criterion": "largest dense robust margin among verified layouts (as "
                             "bridgeflap.design.control.solve.start.select_start); K(s) "
                             "re-optimised per "
                             "layout "
                              "with "
                             "cutting planes and verified like the rounded layout's",
                "start": self.start, "n_layouts": len(self.rows), "time_s": self.time_s,
                "rows": [r.to_dict() for r in self.rows]}

    def table(self) -> str:
        """Plain-text table, one line per layout: the verified ones by rank, then the rest."""
        head = (f"{'rank':>4} {'kind':<12} {'flaps':>5} {'changed':>8} {'|x| span [m]':>15} "
                f"{'z':>6} "
                f"{'verified':>8} {'margin':>8} {'gap %':>7} {'stable to':>9} "
                f"{'max gain':>8}  status")
        lines = [head]
        for r in sorted(self.rows, key=lambda r: r.rank or len(self.rows) + 1):
            d = r.to_dict()
            ax = [abs(p) for p in d["flap_positions_m"]]
            span = f"{min(ax):.1f}-{max(ax):.1f}" if ax else "-"

            def f(v, fmt):
                return fmt.format(v) if v is not None else "nan"
            ch = (f"+-{d['changed_radius_m']:.1f}" if d["changed_radius_m"] is not None
                  else "-")
            lines.append(f"{d['rank'] or '-':>4} {d['kind']:<12} {d['flap_count']:>5} "
                         f"{ch:>8} {span:>15} "
                         f"{f(d['weight_relaxed'], '{:.3f}'):>6} {str(d['verified']):>8} "
                         f"{f(d['robust_margin'], '{:.4f}'):>8} "
                         f"{f(d['gap_to_rounded_pct'], '{:+.2f}'):>7} "
                         f"{f(d['stable_to_m_s'], '{:.2f}'):>9} "
                         f"{f(d['max_gain'], '{:.3f}'):>8}  {d['status']}")
        return "\n".join(lines)


def compare_layouts(settings, positions, theta0, spec=None, variants=(), weights=None,
                    blocks=1, rounded_record=None, log=None, pool=None) -> LayoutComparison:
    """The rounded layout ``positions`` [m] against its neighbours at re-optimised K(s).

    Parameters
    ----------
    settings : DesignSettings
        The design's settings (candidates ``settings.positions()``).
    positions : array_like
        The rounded layout's flap centres [m].
    theta0 : array_like
        Start (b2, b1, b0, a2, a1) of every re-optimisation (e.g. the design's K).
    spec : bridgeflap.model.structure.spec.BridgeSpec, optional
    variants : sequence of BridgeSpec
        Multi-model design variants (as the design's).
    weights : array_like, optional
        Relaxed per-candidate weights (``StartRecord.weights_continuous``): the flipped
        group's ``z`` is reported.
    blocks : int
        Centred blocks of ``g +- blocks`` groups (:func:`neighbour_layouts`).
    rounded_record : StartRecord, optional
        The design's own record of the rounded layout (not re-solved); None re-solves it from
        ``theta0`` like the others.
    log : callable, optional
        ``str -> None``, one line per layout.
    pool : concurrent.futures.Executor, optional
        Layouts solved in its workers.
    """
    import time

    from bridgeflap.design.control.solve import start

    t0 = time.perf_counter()
    log = log or (lambda msg: None)
    cand = settings.positions()
    layouts = neighbour_layouts(cand, positions, settings.symmetric_layout, blocks)
    S = layout_groups(cand, settings.symmetric_layout)
    z = (np.linalg.lstsq(S, np.asarray(weights, float), rcond=None)[0]
         if weights is not None else None)
    todo = [k for k in range(len(layouts)) if k > 0 or rounded_record is None]
    args = [(settings, cand[layouts[k]["mask"] > 0.5], theta0, k, spec, variants)
            for k in todo]
    def done(k, r):
        log(f"layout {k} {layouts[k]['kind']} ({int(layouts[k]['mask'].sum())} flaps, "
            f"|x| <= {np.abs(cand[layouts[k]['mask'] > 0.5]).max():g} m): {r.ipopt_status}, "
            f"verified {r.verified}, margin {r.robust_margin:.4g}, stable to "
            f"{r.stable_to_m_s:g} m/s, max gain {r.max_gain:.4g}, {r.time_s:.0f} s")
        return r

    if pool is not None:
        futs = [pool.submit(start.layout_record, *a) for a in args]
        got = [done(k, f.result()) for k, f in zip(todo, futs, strict=True)]
    else:
        got = [done(k, start.layout_record(*a)) for k, a in zip(todo, args, strict=True)]
    recs = dict(zip(todo, got, strict=True))
    if rounded_record is not None:
        recs[0] = rounded_record
    m0 = recs[0].robust_margin if recs[0].verified else NAN
    rows = []
    for k, lay in enumerate(layouts):
        r = recs[k]
        gap = (100.0 * (r.robust_margin - m0) / m0 if np.isfinite(m0) and m0 > 0
               and r.verified else NAN)
        zj = float(z[lay["group"]]) if z is not None and lay["group"] is not None else NAN
        rows.append(LayoutRow(lay["kind"], lay["group"], lay["group_radius_m"], zj, r, gap))
    ok = [k for k, r in enumerate(rows) if r.record.verified
          and np.isfinite(r.record.robust_margin)]
    ranked = sorted(ok, key=lambda k: (-rows[k].record.robust_margin, k))
    rank = {k: i + 1 for i, k in enumerate(ranked)}
    rows = [LayoutRow(r.kind, r.group, r.group_radius_m, r.weight_relaxed, r.record,
                      r.gap_pct, rank.get(k)) for k, r in enumerate(rows)]
    best = ranked[0] if ranked else None
    nb = [k for k in ranked if k > 0]
    gap = rows[nb[0]].gap_pct if nb else NAN
    if 0 in ok:
        status = "ok" if nb else "no_neighbour_verified"
    else:
        status = "rounded_not_verified" if nb else "none_verified"
    is_rounded = None if best is None else best == 0
    return LayoutComparison(status=status, rows=tuple(rows), best=best,
                            best_layout_is_rounded=is_rounded, best_neighbour_gap_pct=gap,
                            start=("the design's record (rounded), theta0 (neighbours)"
                                   if rounded_record is not None else "theta0 (every layout)"),
                            time_s=time.perf_counter() - t0)


def relaxed_theta(record) -> np.ndarray | None:
    """The K(s) the rounded layout's re-optimisation started from in
    :func:`bridgeflap.design.control.solve.start.run_start`: the chosen round of the relaxed
    (placement) solve, or None without placement rounds."""
    relaxed = [r for r in record.rounds if r.placement != "rounded"]
    if not relaxed or len(relaxed) == len(record.rounds):
        return None
    chosen = [r for r in relaxed if r.chosen] or relaxed[-1:]
    return np.asarray(chosen[0].theta, float)


def design_step(settings, best, status, spec=None, variants=(), log=None):
    """The ``layout_neighbours`` step of :func:`bridgeflap.design.control.search.driver.design` on
    its chosen start.

    The rounded layout's row is the design's own record (not re-solved; the same machinery,
    ``tests/test_layout_search.py``); every neighbour is re-optimised from the design's K.
    With ``layout_adopt`` the best verified neighbour replaces ``best`` when it beats the
    rounded layout (or the rounded layout is not verified), keeping the start's index, and the
    status becomes ``converged`` (it is verified). Returns ``(best, status, dict)`` (None when
    the card's ``layout_neighbours`` is false).
    """
    from dataclasses import replace

    if not settings.layout_neighbours:
        return best, status, None
    if best is None or best.failed:
        return best, status, {"status": "not_run: no design", "rows": []}
    pool = None
    if settings.parallel:
        from bridgeflap.model.workers import process_pool

        pool = process_pool(2)
    try:
        comp = compare_layouts(settings, best.flap_positions_m, best.theta, spec, variants,
                               weights=best.weights_continuous, rounded_record=best, log=log,
                               pool=pool)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    if settings.layout_adopt and comp.best is not None and comp.best != 0:
        best, status = replace(comp.best_record, start=best.start), "converged"
        comp = replace(comp, adopted=True)
        (log or (lambda msg: None))(
            f"layout: adopted the {comp.rows[comp.best].kind} neighbour "
            f"({len(best.flap_positions_m)} flaps, margin {best.robust_margin:.4g})")
    return best, status, comp.to_dict()
