"""Do no harm: a controller judged on bridges it was not designed on (issue 28 item 1).

For each of ``count`` fresh variants sampled (Sobol', :func:`design.designs.sobol`) over the
uncertainty set of the estimated inputs (:data:`design.screening.DEFAULT_UNCERTAIN_RANGES`
less the inputs held fixed), the variant's **open-loop** critical speed (flutter or divergence,
whichever comes first) is set against its **closed-loop** one with the controller's flaps, both
from the same sweep on the same grid and mode count (:func:`model.analysis.closed_loop_flutter`).

A variant is *harmed* when the closed loop goes unstable below the open loop's critical speed
(by more than :data:`HARM_TOL_REL`: Brent stops each crossing at 1e-3 m/s, so a smaller
difference is the same speed). A crossing that is neither converged nor absent from the grid
(``unverified_crossing``, ``bracket_failed``, ``unstable_at_first_speed``) and whose grid
bracket does not lie above the converged critical speed makes its row ``unresolved``: it is
counted apart, never as a pass. A speed beyond the grid is reported as
``null`` with ``*_beyond_grid`` true (a lower bound: the grid's last speed).

The summary gives the fraction stable to the design speed, the fraction harmed, the worst
closed/open ratio and the worst variant; the rows are a table (``to_dataframe``).

``method`` (:data:`HARM_METHODS`): ``"reference"`` is the full fast sweep of each loop
(:func:`model.stability.sweep`, ``method="fast"``: labels confirmed, the second-critical
branch, the whole dense sweep where Newton is unsure); ``"fast"`` (the default) reads the
same crossings with ``critical_only`` (no labels, no second branch, a crossing Newton misses
kept from its 0.5 m/s grid bracket) on a modal model that solves only the retained modes'
labels. The verdict reads nothing else, so both give the same rows to the crossings'
tolerance (docs/methods.md#fast-do-no-harm-check; tests/test_harm_fast.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model.errors import BridgeflapInputError
from model.results import ResultData

__all__ = ["DEFAULT_SCREEN_MODES", "HARM_METHODS", "HARM_TOL_REL", "SCREEN_MARGIN_REL",
           "HarmResult", "do_no_harm", "harm_row", "near_decision"]

#: ``method`` of :func:`do_no_harm` and :func:`harm_row`: ``"fast"`` (default) or the
#: ``"reference"`` (the module docstring)
HARM_METHODS = ("fast", "reference")

#: closed-loop critical speed below ``(1 - HARM_TOL_REL)`` x the open-loop one is harm: the
#: crossings are refined to 1e-3 m/s (Brent), 1e-4 relative at 10 m/s and more
HARM_TOL_REL = 1e-4
#: a screened row within this relative distance of a decision (the design speed; the open-loop
#: speed: twice it) is recomputed on all modes. 16 modes against 30: the largest change of a
#: critical speed is 0.70 % over the 66 cases of model.analysis.DEFAULT_MODES (the open loop at
#: the 64 corners of the input ranges) and 0.095 % over 16 sampled variants of the default
#: design (closed loop: its static divergence, +0.08..0.095 %); 1.5 % is twice the first. The
#: margin is checked a posteriori on every recomputed row (SCREEN_CHECK_FRACTION)
SCREEN_MARGIN_REL = 0.015
#: the largest 16-vs-30 change seen on the recomputed rows must stay below this fraction of
#: the margin, else every screened row is recomputed (the screening is not trusted)
SCREEN_CHECK_FRACTION = 1 / 3
#: modes of the fast method's screening (model.analysis.DEFAULT_MODES' 16-mode count)
DEFAULT_SCREEN_MODES = 16
#: statuses that are a result: a crossing found and verified, or none on the grid
_RESOLVED = ("converged", "no_crossing_in_range")
#: inputs held at their nominal value: the half-chord is a reading of the geometry, not an
#: uncertainty of one bridge (the flap chord and positions are fixed to it), and the coherence
#: decay enters buffeting only
DEFAULT_FIXED = ("deck.half_chord_m", "aero.coherence_decay")


def _check_method(method) -> None:
    if method not in HARM_METHODS:
        raise BridgeflapInputError("method", f"must be one of {HARM_METHODS}, got {method!r}")


def _crit(summary: dict) -> tuple[float, str, bool]:
    """(critical speed [m/s] or inf beyond the grid, mechanism, resolved) of a summary.

    Resolved: every crossing is converged or absent, or the converged critical speed lies
    below the grid bracket of each crossing that is not (the lower crossing governs, whatever
    the unverified one above it is: the closed-loop divergence of the default design is
    ``unverified_crossing`` with a bracket above its flutter speed).
    """
    u = summary.get("critical_speed_m_s")
    u = math.inf if u is None or not np.isfinite(u) else float(u)
    lows = []
    for kind in ("flutter", "divergence"):
        if summary.get(f"{kind}_status") in _RESOLVED:
            continue
        bracket = summary.get(f"{kind}_bracket_m_s")
        lows.append(float(bracket[0]) if bracket else -math.inf)  # no bracket: unknown
    resolved = all(u <= lo for lo in lows) and not (lows and math.isinf(u))
    mech = "none" if math.isinf(u) else str(summary.get("critical_mechanism", ""))
    return u, mech, resolved


def _verdict(res, speed_max_m_s: float, n_modes: int) -> dict:
    """The row of one :class:`model.analysis.ClosedLoopFlutterResult`."""
    cl, cl_mech, cl_ok = _crit(res.base.summary())
    ol, ol_mech, ol_ok = _crit(res.open_loop.summary())
    resolved = cl_ok and ol_ok
    if math.isinf(ol) and math.isinf(cl):
        ratio = None  # both beyond the grid: nothing to compare
    elif math.isinf(cl):
        ratio = None  # closed loop beyond the grid: at least speeds[-1] / ol
    else:
        ratio = cl / ol if not math.isinf(ol) else 0.0  # open loop beyond the grid: harm
    harmed = resolved and cl < ol * (1.0 - HARM_TOL_REL)
    return {
        "open_loop_critical_speed_m_s": None if math.isinf(ol) else ol,
        "open_loop_beyond_grid": math.isinf(ol), "open_loop_mechanism": ol_mech,
        "closed_loop_critical_speed_m_s": None if math.isinf(cl) else cl,
        "closed_loop_beyond_grid": math.isinf(cl), "closed_loop_mechanism": cl_mech,
        "closed_over_open": ratio,
        "stable_to_design_speed": bool(resolved and cl > speed_max_m_s),
        "harmed": bool(harmed), "resolved": bool(resolved), "modes": int(n_modes),
    }


def harm_row(spec, controller, speeds, n_modes: int, speed_max_m_s: float,
             sweep_method: str = "fast", method: str = "reference",
             screen_modes: int | None = None) -> dict:
    """One variant's open- and closed-loop critical speeds and the harm verdict.

    ``method``: :data:`HARM_METHODS`. ``"fast"`` reads the critical crossings alone
    (``critical_only``) on a modal model of the retained modes (``sweep_method`` is ignored:
    always the fast sweep); with ``screen_modes < n_modes`` it first screens the variant on
    ``screen_modes`` and keeps that row (``modes`` says which) unless it lies near a decision
    (:func:`near_decision`), where the row is recomputed on ``n_modes``. The screened speeds
    are kept under ``screen_*`` for :func:`do_no_harm`'s a-posteriori check.
    """
    from model.analysis import closed_loop_flutter

    _check_method(method)
    if method == "reference":
        res = closed_loop_flutter(spec, controller, speeds, n_modes, sweep_method=sweep_method,
                                  verify_static=False)  # the verdict reads the sweep alone
        return _verdict(res, speed_max_m_s, n_modes)
    from model.fe import assemble
    from model.modes import solve

    # the lowest n_modes of each family hold the lowest n_modes of both together: the same
    # basis, labels and Rayleigh damping as all modes (modes.solve), fewer modes labelled
    modal = solve(assemble(spec), int(n_modes))

    def at(m):
        return _verdict(closed_loop_flutter(spec, controller, speeds, m, sweep_method="fast",
                                            verify_static=False, critical_only=True,
                                            modal=modal), speed_max_m_s, m)

    screen = {"screen_open_loop_critical_speed_m_s": None,
              "screen_closed_loop_critical_speed_m_s": None}
    if screen_modes is not None and int(screen_modes) < int(n_modes):
        row = at(int(screen_modes))
        screen = {f"screen_{k}": row[k] for k in ("open_loop_critical_speed_m_s",
                                                  "closed_loop_critical_speed_m_s")}
        if not near_decision(row, speed_max_m_s):
            return {**row, **screen}
    return {**at(int(n_modes)), **screen}


def near_decision(row: dict, speed_max_m_s: float, margin: float | None = None) -> bool:
    """Whether a screened row's verdict could change on more modes.

    Near: not resolved, a critical speed beyond the grid, the closed-loop critical speed
    within ``margin`` (default :data:`SCREEN_MARGIN_REL`) of the design speed, or the
    closed/open ratio within ``2 margin`` of 1 (both speeds may move).
    """
    m = SCREEN_MARGIN_REL if margin is None else float(margin)
    cl, ol = row["closed_loop_critical_speed_m_s"], row["open_loop_critical_speed_m_s"]
    if not row["resolved"] or cl is None or ol is None:
        return True
    return abs(cl / speed_max_m_s - 1.0) <= m or abs(cl / ol - 1.0) <= 2 * m


@dataclass(frozen=True)
class HarmResult(ResultData):
    """The do-no-harm table of one controller over ``count`` fresh variants."""

    bridge: str
    count: int
    n_modes: int
    speed_max_m_s: float
    speeds_max_m_s: float
    seed: int
    ranges: dict
    rows: tuple = field(repr=False)
    method: str = "reference"
    #: modes of the fast method's screening (None: every row on ``n_modes``)
    screen_modes: int | None = None
    #: the a-posteriori check of the screening (:func:`do_no_harm`)
    screen_check: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """Fractions, the worst ratio and its variant (strict-JSON ready)."""
        n = max(len(self.rows), 1)
        ratios = [(r["closed_over_open"], i) for i, r in enumerate(self.rows)
                  if r["resolved"] and r["closed_over_open"] is not None]
        worst = min(ratios) if ratios else (None, None)
        harmed = [i for i, r in enumerate(self.rows) if r["harmed"]]
        unresolved = sum(not r["resolved"] for r in self.rows)
        return {
            "bridge": self.bridge, "variants": len(self.rows), "modes": self.n_modes,
            "seed": self.seed, "design_speed_m_s": self.speed_max_m_s,
            "grid_max_m_s": self.speeds_max_m_s,
            "fraction_stable_to_design_speed":
                sum(r["stable_to_design_speed"] for r in self.rows) / n,
            "fraction_harmed": len(harmed) / n, "harmed_variants": harmed,
            "unresolved_variants": unresolved,
            "worst_closed_over_open": worst[0], "worst_variant": worst[1],
            "worst_closed_loop_critical_speed_m_s": min(
                (r["closed_loop_critical_speed_m_s"] for r in self.rows
                 if r["closed_loop_critical_speed_m_s"] is not None), default=None),
            "status": ("unresolved" if unresolved else "harm" if harmed else "no_harm"),
            "ranges": {k: list(v) for k, v in self.ranges.items()},
            "method": self.method, "screen_modes": self.screen_modes,
            "variants_on_all_modes": sum(r.get("modes", self.n_modes) == self.n_modes
                                         for r in self.rows),
            **({"screen_check": dict(self.screen_check)} if self.screen_check else {}),
        }

    def to_dataframe(self):
        """One row per variant: its inputs and the verdict (unit-named columns)."""
        import pandas as pd

        return pd.DataFrame([{"variant": i, **r} for i, r in enumerate(self.rows)])


def _sample(spec, ranges: dict, count: int, seed: int) -> list[tuple[dict, object]]:
    from design.designs import sobol

    return [({k: float(v) for k, v in case.items() if k in ranges},
             spec.replace(**{k: v for k, v in case.items() if k in ranges}))
            for case in sobol(ranges, int(count), int(seed))]


def _rows_of(chunk, controller, speeds, n_modes, speed_max, method="reference",
             screen_modes=None):
    return [{**params, **harm_row(v, controller, speeds, n_modes, speed_max, method=method,
                                  screen_modes=screen_modes)}
            for params, v in chunk]


def do_no_harm(controller, bridge="humber", count: int = 200, seed: int = 11,
               n_modes: int = 30, speed_max_m_s: float = 85.0, speeds=None,
               ranges: dict | None = None, fixed=DEFAULT_FIXED, workers: int = 1,
               progress=None, method: str = "fast",
               screen_modes: int | None = DEFAULT_SCREEN_MODES) -> HarmResult:
    """Open- against closed-loop critical speed of ``controller`` on ``count`` fresh variants.

    Parameters
    ----------
    controller : model.control.Controller
        The loop (its own flap chord and layout).
    bridge : str or BridgeSpec
        The nominal bridge (built-in name, TOML path, or a spec).
    count, seed : int
        Sobol' sample size and scramble seed (another seed: other variants).
    n_modes : int
        Retained modes of every variant's model (of every row's numbers with
        ``method="reference"`` or ``screen_modes=None``).
    speed_max_m_s : float
        The design speed: "stable to the design speed" is a closed-loop critical speed above it.
    speeds : array, optional
        The sweep grid [m/s]; default ``0 .. 1.5 speed_max`` in 0.5 m/s steps, so that a
        closed loop that lifts the critical speed is still compared, not clipped.
    ranges : dict, optional
        Input path -> (low, high) [SI]; default the estimated-input ranges less ``fixed``.
    workers : int
        Processes (one variant per task).
    method : {"fast", "reference"}
        :data:`HARM_METHODS` (the module docstring).
    screen_modes : int or None
        ``method="fast"``: screen every variant on this many modes first (ignored unless
        below ``n_modes``). A row near a decision (:func:`near_decision`) and every row near
        the reported extremes (the worst ratio within ``2`` :data:`SCREEN_MARGIN_REL`, the
        lowest closed-loop speed within one) is on ``n_modes``; the largest screening change
        seen on those rows must stay below :data:`SCREEN_CHECK_FRACTION` of the margin, else
        every row is recomputed on ``n_modes`` (``screen_check``).
    """
    from design.screening import DEFAULT_UNCERTAIN_RANGES
    from model.spec import BridgeSpec, load_bridge

    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 4096:
        raise BridgeflapInputError("count", f"must be an integer in [1, 4096], got {count!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BridgeflapInputError("workers", f"must be an integer >= 1, got {workers!r}")
    if not (np.isfinite(speed_max_m_s) and speed_max_m_s > 0):
        raise BridgeflapInputError("speed_max_m_s", f"must be positive, got {speed_max_m_s}")
    _check_method(method)
    if screen_modes is not None and (isinstance(screen_modes, bool)
                                     or not isinstance(screen_modes, int) or screen_modes < 1):
        raise BridgeflapInputError("screen_modes",
                                   f"must be a positive integer or None, got {screen_modes!r}")
    screen = (screen_modes if method == "fast" and screen_modes is not None
              and screen_modes < n_modes else None)
    spec = bridge if isinstance(bridge, BridgeSpec) else load_bridge(bridge)
    name = bridge if isinstance(bridge, str) else spec.name
    if ranges is None:
        ranges = {k: v for k, v in DEFAULT_UNCERTAIN_RANGES.items() if k not in set(fixed)}
    u = (np.arange(0.0, 1.5 * speed_max_m_s + 1e-9, 0.5) if speeds is None
         else np.asarray(speeds, dtype=float))
    samples = _sample(spec, dict(ranges), count, seed)
    say = progress or (lambda msg: None)
    say(f"do no harm: {count} variants x 2 sweeps ({n_modes} modes"
        f"{f', screened on {screen}' if screen else ''}, 0..{u[-1]:g} m/s, {method})")
    with _Runner(workers, controller, u, n_modes, speed_max_m_s, method, say) as run:
        rows = run(samples, range(len(samples)), screen)
        check = {}
        if screen:
            rows, check = _confirm(run, samples, rows, n_modes, speed_max_m_s, say)
    return HarmResult(bridge=str(name), count=count, n_modes=int(n_modes),
                      speed_max_m_s=float(speed_max_m_s), speeds_max_m_s=float(u[-1]),
                      seed=int(seed), ranges=dict(ranges), rows=tuple(rows), method=method,
                      screen_modes=screen, screen_check=check)


class _Runner:
    """Rows of chosen samples, serially or in one process pool kept for every pass."""

    def __init__(self, workers, controller, speeds, n_modes, speed_max, method, say):
        self.args = (controller, speeds, n_modes, speed_max, method)
        self.workers, self.say, self.ex = workers, say, None

    def __enter__(self):
        if self.workers > 1:
            from concurrent.futures import ProcessPoolExecutor

            self.ex = ProcessPoolExecutor(max_workers=self.workers)
        return self

    def __exit__(self, *exc):
        if self.ex is not None:
            self.ex.shutdown(cancel_futures=True)

    def __call__(self, samples, indices, screen_modes) -> list:
        indices = list(indices)
        rows: dict = {}
        step = max(1, len(indices) // 10)

        def done(i, row):
            rows[i] = row
            if len(rows) % step == 0 or len(rows) == len(indices):
                self.say(f"do no harm: {len(rows)}/{len(indices)} variants")

        if self.ex is None:
            for i in indices:
                done(i, _rows_of([samples[i]], *self.args, screen_modes)[0])
        else:
            from concurrent.futures import as_completed

            futures = {self.ex.submit(_rows_of, [samples[i]], *self.args, screen_modes): i
                       for i in indices}
            for f in as_completed(futures):
                done(futures[f], f.result()[0])
        return [rows[i] for i in indices]


def _extreme_candidates(rows, n_modes) -> list[int]:
    """Screened rows that may hold the summary's worst ratio or lowest closed-loop speed."""
    m = SCREEN_MARGIN_REL
    ratios = [r["closed_over_open"] for r in rows
              if r["resolved"] and r["closed_over_open"] is not None]
    speeds = [r["closed_loop_critical_speed_m_s"] for r in rows
              if r["closed_loop_critical_speed_m_s"] is not None]
    r_min, u_min = min(ratios, default=None), min(speeds, default=None)
    out = []
    for i, r in enumerate(rows):
        if r["modes"] == n_modes:
            continue
        q, cl = r["closed_over_open"], r["closed_loop_critical_speed_m_s"]
        if ((r_min is not None and q is not None and q <= r_min * (1 + 2 * m))
                or (u_min is not None and cl is not None and cl <= u_min * (1 + m))):
            out.append(i)
    return out


def _screen_change(rows, n_modes) -> float:
    """The largest relative change of a critical speed from its screening, over the rows
    recomputed on ``n_modes`` (0 when none has both)."""
    worst = 0.0
    for r in rows:
        if r["modes"] != n_modes:
            continue
        for k in ("open_loop_critical_speed_m_s", "closed_loop_critical_speed_m_s"):
            a, b = r.get(f"screen_{k}"), r[k]
            if a is not None and b is not None:
                worst = max(worst, abs(b / a - 1.0))
    return worst


def _confirm(run, samples, rows, n_modes, speed_max, say):
    """Rows near the reported extremes on ``n_modes``, then the a-posteriori check."""
    rows = list(rows)

    def redo(idx):
        for i, new in zip(idx, run(samples, idx, None), strict=True):
            keep = {k: rows[i][k] for k in ("screen_open_loop_critical_speed_m_s",
                                            "screen_closed_loop_critical_speed_m_s")}
            rows[i] = {**new, **keep}

    for _ in range(len(rows)):  # each pass recomputes at least one row, or stops
        idx = _extreme_candidates(rows, n_modes)
        if not idx:
            break
        say(f"do no harm: {len(idx)} variants near the extremes on {n_modes} modes")
        redo(idx)
    change = _screen_change(rows, n_modes)
    limit = SCREEN_CHECK_FRACTION * SCREEN_MARGIN_REL
    check = {"margin_rel": SCREEN_MARGIN_REL, "largest_change_rel": change,
             "limit_rel": limit, "rows_compared": sum(r["modes"] == n_modes for r in rows),
             "passed": change <= limit}
    if not check["passed"]:
        idx = [i for i, r in enumerate(rows) if r["modes"] != n_modes]
        say(f"do no harm: screening change {100 * change:.2f} % above {100 * limit:.2f} %: "
            f"{len(idx)} more variants on {n_modes} modes")
        redo(idx)
    return rows, check
