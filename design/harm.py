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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model.errors import BridgeflapInputError
from model.results import ResultData

__all__ = ["HARM_TOL_REL", "HarmResult", "do_no_harm", "harm_row"]

#: closed-loop critical speed below ``(1 - HARM_TOL_REL)`` x the open-loop one is harm: the
#: crossings are refined to 1e-3 m/s (Brent), 1e-4 relative at 10 m/s and more
HARM_TOL_REL = 1e-4
#: statuses that are a result: a crossing found and verified, or none on the grid
_RESOLVED = ("converged", "no_crossing_in_range")
#: inputs held at their nominal value: the half-chord is a reading of the geometry, not an
#: uncertainty of one bridge (the flap chord and positions are fixed to it), and the coherence
#: decay enters buffeting only
DEFAULT_FIXED = ("deck.half_chord_m", "aero.coherence_decay")


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


def harm_row(spec, controller, speeds, n_modes: int, speed_max_m_s: float,
             sweep_method: str = "fast") -> dict:
    """One variant's open- and closed-loop critical speeds and the harm verdict."""
    from model.analysis import closed_loop_flutter

    res = closed_loop_flutter(spec, controller, speeds, n_modes, sweep_method=sweep_method,
                              verify_static=False)  # the verdict reads the sweep alone
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
        "harmed": bool(harmed), "resolved": bool(resolved),
    }


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
        }

    _HEADLINE_KEYS = ("bridge", "variants", "modes", "design_speed_m_s",
                      "fraction_stable_to_design_speed", "fraction_harmed",
                      "worst_closed_over_open", "worst_closed_loop_critical_speed_m_s", "status")

    def plot(self, ax=None):
        """Histogram of the closed- over open-loop critical speed of the variants [-]
        (:func:`design.result_plots.harm_ratios`)."""
        from design.result_plots import harm_ratios

        return harm_ratios(self, ax)

    def to_dataframe(self):
        """One row per variant: its inputs and the verdict (unit-named columns)."""
        import pandas as pd

        return pd.DataFrame([{"variant": i, **r} for i, r in enumerate(self.rows)])


def _sample(spec, ranges: dict, count: int, seed: int) -> list[tuple[dict, object]]:
    from design.designs import sobol

    return [({k: float(v) for k, v in case.items() if k in ranges},
             spec.replace(**{k: v for k, v in case.items() if k in ranges}))
            for case in sobol(ranges, int(count), int(seed))]


def _rows_of(chunk, controller, speeds, n_modes, speed_max):
    return [{**params, **harm_row(v, controller, speeds, n_modes, speed_max)}
            for params, v in chunk]


def do_no_harm(controller, bridge="humber", count: int = 200, seed: int = 11,
               n_modes: int = 30, speed_max_m_s: float = 85.0, speeds=None,
               ranges: dict | None = None, fixed=DEFAULT_FIXED, workers: int = 1,
               progress=None) -> HarmResult:
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
        Retained modes of every variant's model.
    speed_max_m_s : float
        The design speed: "stable to the design speed" is a closed-loop critical speed above it.
    speeds : array, optional
        The sweep grid [m/s]; default ``0 .. 1.5 speed_max`` in 0.5 m/s steps, so that a
        closed loop that lifts the critical speed is still compared, not clipped.
    ranges : dict, optional
        Input path -> (low, high) [SI]; default the estimated-input ranges less ``fixed``.
    workers : int
        Processes (the variants in ``workers`` chunks).
    """
    from design.screening import DEFAULT_UNCERTAIN_RANGES
    from model.spec import BridgeSpec, load_bridge

    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 4096:
        raise BridgeflapInputError("count", f"must be an integer in [1, 4096], got {count!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BridgeflapInputError("workers", f"must be an integer >= 1, got {workers!r}")
    if not (np.isfinite(speed_max_m_s) and speed_max_m_s > 0):
        raise BridgeflapInputError("speed_max_m_s", f"must be positive, got {speed_max_m_s}")
    spec = bridge if isinstance(bridge, BridgeSpec) else load_bridge(bridge)
    name = bridge if isinstance(bridge, str) else spec.name
    if ranges is None:
        ranges = {k: v for k, v in DEFAULT_UNCERTAIN_RANGES.items() if k not in set(fixed)}
    u = (np.arange(0.0, 1.5 * speed_max_m_s + 1e-9, 0.5) if speeds is None
         else np.asarray(speeds, dtype=float))
    samples = _sample(spec, dict(ranges), count, seed)
    say = progress or (lambda msg: None)
    say(f"do no harm: {count} variants x 2 sweeps ({n_modes} modes, 0..{u[-1]:g} m/s)")
    rows: list = [None] * len(samples)
    step = max(1, len(samples) // 10)

    def done(i, row):
        rows[i] = row
        n = sum(r is not None for r in rows)
        if n % step == 0 or n == len(samples):
            say(f"do no harm: {n}/{len(samples)} variants")

    if workers == 1:
        for i, sample in enumerate(samples):
            done(i, _rows_of([sample], controller, u, n_modes, speed_max_m_s)[0])
    else:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(max_workers=workers) as ex:
            futures = {ex.submit(_rows_of, [sample], controller, u, n_modes, speed_max_m_s): i
                       for i, sample in enumerate(samples)}
            for f in as_completed(futures):
                done(futures[f], f.result()[0])
    return HarmResult(bridge=str(name), count=count, n_modes=int(n_modes),
                      speed_max_m_s=float(speed_max_m_s), speeds_max_m_s=float(u[-1]),
                      seed=int(seed), ranges=dict(ranges), rows=tuple(rows))
