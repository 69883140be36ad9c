"""Fail-safe flaps: the closed loop with each single flap pair failed.

A *flap pair* is the LE+TE flaps at one strip of the controller's layout (one pitch input, one
drive angle ``beta_f = K alpha_f``; :mod:`bridgeflap.model.aeroelastic.flaps`). For every pair
``f``:

* **stuck at 0** -- the pair's drive removed from the loop: its flap loads get weight 0
  (:meth:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel.system`, the same weights as the flap
  placement), the other pairs still driven by ``K(s)``. Its compensator states stay, uncoupled, with
  their own stable poles;
* **stuck at an angle** ``delta`` (default :data:`DEFAULT_STUCK_ANGLE_DEG`) -- a constant input
  on the same ``A(U)``: the *linear stability equals that of the pair stuck at 0*. It adds the
  static deflection of ``K_ae(U) q = U^2 f_f delta``
  (:func:`bridgeflap.model.stability.static_divergence .static_response`; ``K_ae`` of the loop with
  pair ``f`` failed, the others at their static gain ``K(0)``; ``f_f`` the static load of pair ``f``
  per ``U^2`` and unit drive angle), which grows without bound as ``U`` approaches that loop's
  static divergence root;
* and the **controller switched off**: every weight 0, which must be the open loop.

Each case gets the sweep of :func:`bridgeflap.model.stability.sweeps.sweep` (flutter and divergence
with the verified-crossing statuses; ``critical_only``: the crossings without the branch labels
and the second branch, which no row reads), the verified static divergence
(:mod:`bridgeflap.model.stability.static_divergence`), and the critical speed by the rule of
:mod:`bridgeflap.design.assessment.harm` (:func:`bridgeflap.design.assessment.harm._crit`: a
crossing that is neither converged nor absent must lie above the converged critical speed, else the
row is unresolved); a verified static root that is a stability limit stands for an unverified
dynamic divergence. Ratios are to the intact closed loop and to the open loop on the same grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.progress import Eta
from bridgeflap.model.results import ResultData

__all__ = ["DEFAULT_STUCK_ANGLE_DEG", "FailSafeResult", "single_pair_failures"]

#: default angle [deg] of a flap pair stuck away from 0 (drive angle, both flaps of the pair)
DEFAULT_STUCK_ANGLE_DEG = 5.0
#: fractions of the design speed at which the stuck pair's static deflection is reported (and
#: 0.95 of that loop's static divergence root, where it lies inside the grid)
STATIC_SPEED_FRACTIONS = (0.5, 0.75, 1.0)
STUCK_NOTE = ("a pair stuck at a fixed angle is a constant input on the same A(U) as the pair "
              "stuck at 0: its linear stability (critical speed, mechanism, status) is that "
              "row's; it adds the static deflection K_ae(U) q = U^2 f delta of stuck_response")


def _edges(controller) -> str:
    return "+".join(e for e, on in (("LE", controller.leading_edge),
                                    ("TE", controller.trailing_edge)) if on)


def _case(model, compensator, weights, speeds, method, grid_max):
    """Sweep summary and verified static divergence of one loop (a worker's job)."""
    from bridgeflap.model.stability.static_divergence import static_divergence
    from bridgeflap.model.stability.sweeps import sweep

    system = (model.open_loop if weights is None
              else model.system(compensator, np.asarray(weights, float)))
    # the crossings alone (critical_only: no branch labels, no second branch): a row reads
    # the flutter and divergence speeds and statuses, which are the full sweep's
    s = sweep(system, speeds, method=method, critical_only=True).summary()
    from bridgeflap.model.analysis import critical_speed

    s.update(critical_speed(s))
    return s, static_divergence(system, grid_max)


def _lower_bound(s: dict, grid_max: float):
    """Lowest speed [m/s] at which the loop may go unstable: the converged limits and the grid
    bracket's lower end of every crossing seen but not converged; the grid's last speed when
    nothing crosses on it; None when unstable at the first speed (or no bracket is known)."""
    lows = []
    for kind in ("flutter", "divergence"):
        st = s.get(f"{kind}_status")
        if st == "converged":
            lows.append(float(s[f"{kind}_speed_m_s"]))
        elif st == "no_crossing_in_range":
            continue
        elif s.get(f"{kind}_bracket_m_s") and st != "unstable_at_first_speed":
            lows.append(float(s[f"{kind}_bracket_m_s"][0]))
        else:
            return None
    return min(lows) if lows else float(grid_max)


def _stability(summary: dict, static, grid_max: float, design_speed: float) -> dict:
    """Critical speed, mechanism and resolution of one case (module docstring)."""
    from bridgeflap.design.assessment.harm_verdict import _crit

    s = dict(summary)
    used_static = False
    if static.is_stability_limit and s.get("divergence_status") != "converged":
        s.update(divergence_status="converged", divergence_speed_m_s=static.speed_m_s)
        s.pop("divergence_bracket_m_s", None)
        from bridgeflap.model.analysis import critical_speed

        s.update(critical_speed(s))
        used_static = True
    u, mech, ok = _crit(s)
    if used_static and mech == "divergence":
        mech = "divergence (static)"
    st = static.summary()
    low = _lower_bound(s, grid_max)
    return {"critical_speed_m_s": None if math.isinf(u) or not ok else u,
            "critical_beyond_grid": bool(ok and math.isinf(u)), "critical_mechanism": mech,
            "critical_speed_lower_bound_m_s": low,
            "stable_to_design_speed": bool(low is not None and low > design_speed),
            "resolved": bool(ok), "status": "resolved" if ok else "unresolved",
            "flutter_speed_m_s": summary.get("flutter_speed_m_s"),
            "flutter_frequency_hz": summary.get("flutter_frequency_hz"),
            "flutter_status": summary.get("flutter_status"),
            "divergence_speed_m_s": summary.get("divergence_speed_m_s"),
            "divergence_status": summary.get("divergence_status"),
            "divergence_reason": summary.get("divergence_reason", ""),
            "divergence_static_verified_speed_m_s":
                st["divergence_static_verified_speed_m_s"],
            "divergence_static_verified_status": st["divergence_static_verified_status"],
            "divergence_static_verified_direction":
                st["divergence_static_verified_direction"],
            "divergence_static_root_m_s": st["divergence_static_verified_root_m_s"],
            "divergence_static_dynamic_crossing_m_s":
                st["divergence_static_verified_dynamic_crossing_m_s"],
            "divergence_static_is_stability_limit":
                st["divergence_static_verified_is_stability_limit"],
            "divergence_static_reason": st["divergence_static_verified_reason"]}


def _ratio(u, ref):
    if u is None or ref is None:
        return None
    return float(u) / float(ref)


def _stuck_response(model, compensator, pair, angle_rad, speeds, mid_x) -> list[dict]:
    """Static deflection of pair ``pair`` stuck at ``angle_rad`` at each of ``speeds``."""
    from bridgeflap.model.stability.static_divergence import static_response

    n_f = model.n_flaps
    w = np.ones(n_f)
    w[pair] = 0.0
    system = model.system(compensator, w)
    op = model.pieces(np.ones(n_f))
    PF, (_, g0) = op.W_beta
    load = (op.H[2] + g0 * PF)[:, pair]      # static load per U^2 and unit drive angle
    basis = system.basis
    x = np.asarray(basis.strip_x, float) - mid_x
    rows = []
    for u in speeds:
        q = static_response(system, u, load) * angle_rad
        tw = np.asarray(basis.phi_a, float) @ q
        hv = np.asarray(basis.phi_h, float) @ q
        it, ih = int(np.argmax(np.abs(tw))), int(np.argmax(np.abs(hv)))
        rows.append({"pair": int(pair), "speed_m_s": float(u),
                     "twist_at_flap_deg": float(np.degrees(model.flaps.phi_a[pair] @ q)),
                     "heave_at_flap_m": float(model.flaps.phi_h[pair] @ q),
                     "twist_max_abs_deg": float(np.degrees(abs(tw[it]))),
                     "twist_max_position_m": float(x[it]),
                     "heave_max_abs_m": float(abs(hv[ih])),
                     "heave_max_position_m": float(x[ih])})
    return rows


@dataclass(frozen=True)
class FailSafeResult(ResultData):
    """Single-pair failures of one controller (module docstring); ``rows``: one per pair."""

    bridge: str
    n_modes: int
    speed_max_m_s: float
    speeds_max_m_s: float
    stuck_angle_deg: float
    edges: str
    intact: dict
    open_loop: dict
    controller_off: dict
    rows: tuple = field(repr=False)
    stuck_response: tuple = field(repr=False)

    def __repr__(self) -> str:
        s = self.summary()
        w = s["worst_single_failure"]
        return (f"FailSafeResult({self.bridge!r}, {len(self.rows)} pairs, intact "
                f"{s['intact']['critical_speed_m_s']} m/s, worst pair {w['pair']} at "
                f"{w['critical_speed_m_s']} m/s, status {s['status']!r})")

    @property
    def status(self) -> str:
        """``single_failure_safe``: every one-pair failure stable to the design speed (its
        critical speed, or the lower bound of an unresolved one, above it);
        ``single_failure_unsafe``: a resolved failure goes unstable at or below it;
        ``unresolved``: otherwise (an unresolved row whose lower bound is not above it)."""
        if all(r["stable_to_design_speed"] for r in self.rows):
            return "single_failure_safe"
        if any(r["resolved"] and not r["stable_to_design_speed"] for r in self.rows):
            return "single_failure_unsafe"
        return "unresolved"

    def worst(self) -> dict:
        """The failed pair of lowest critical speed among the resolved rows (beyond the grid
        last); ``resolved``: no unresolved row's lower bound lies below it."""
        keys = ("pair", "position_m", "critical_speed_m_s", "critical_mechanism",
                "over_intact", "over_open_loop")
        rows = [r for r in self.rows if r["resolved"]]
        if not rows:
            return {**dict.fromkeys(keys), "resolved": False}
        r = min(rows, key=lambda r: math.inf if r["critical_beyond_grid"]
                else r["critical_speed_m_s"])
        u = math.inf if r["critical_beyond_grid"] else r["critical_speed_m_s"]
        # the worst is known when no unresolved row may go unstable below it
        known = all(x["resolved"] or (x["critical_speed_lower_bound_m_s"] is not None
                                      and x["critical_speed_lower_bound_m_s"] >= u)
                    for x in self.rows)
        return {**{k: r[k] for k in keys}, "resolved": bool(known)}

    def summary(self) -> dict:
        """Strict-JSON-ready record (NaN mapped to null by the caller's :func:`jsonable`)."""
        off, ol = self.controller_off, self.open_loop
        rel = None
        if off["critical_speed_m_s"] is not None and ol["critical_speed_m_s"] is not None:
            rel = abs(off["critical_speed_m_s"] / ol["critical_speed_m_s"] - 1.0)
        return {"bridge": self.bridge, "modes": self.n_modes,
                "design_speed_m_s": self.speed_max_m_s, "grid_max_m_s": self.speeds_max_m_s,
                "flap_pairs": len(self.rows), "edges": self.edges,
                "stuck_angle_deg": self.stuck_angle_deg, "stuck_at_angle_note": STUCK_NOTE,
                "intact": dict(self.intact), "open_loop": dict(ol),
                "controller_off": dict(off),
                "controller_off_minus_open_loop_relative": rel,
                "worst_single_failure": self.worst(),
                "pairs_stable_to_design_speed": sum(r["stable_to_design_speed"]
                                                    for r in self.rows),
                "unresolved_pairs": [r["pair"] for r in self.rows if not r["resolved"]],
                "failures": [dict(r) for r in self.rows],
                "stuck_response": [dict(r) for r in self.stuck_response],
                "status": self.status}

    def _rows(self) -> list[dict]:
        return [dict(r) for r in self.rows]

    def _headline(self) -> dict:
        s, w = self.summary(), self.worst()
        return {"bridge": self.bridge, "flap_pairs": len(self.rows),
                "design_speed_m_s": self.speed_max_m_s,
                "intact_critical_speed_m_s": self.intact["critical_speed_m_s"],
                "worst_pair": w["pair"], "worst_critical_speed_m_s": w["critical_speed_m_s"],
                "pairs_stable_to_design_speed": s["pairs_stable_to_design_speed"],
                "status": self.status}

    def plot(self, ax=None):
        """Critical speed [m/s] with each flap pair failed, against the pair's position [m]
        (:func:`bridgeflap.design.control.results.result_plots.pair_failures`)."""
        from bridgeflap.design.control.results.result_plots import pair_failures

        return pair_failures(self, ax)


def single_pair_failures(controller, bridge=None, n_modes: int = 30,
                         speed_max_m_s: float = 85.0, speeds=None,
                         stuck_angle_deg: float = DEFAULT_STUCK_ANGLE_DEG,
                         static_speeds_m_s=None, workers: int = 1, sweep_method: str = "fast",
                         progress=None) -> FailSafeResult:
    """Each single flap pair of ``controller`` failed, and the controller off (module docstring).

    Parameters
    ----------
    controller : bridgeflap.model.aeroelastic.control.Controller
        The loop (its own flap chord, width, positions and edges).
    bridge : str or BridgeSpec, optional
        Default: the bridge the controller records (``plant.bridge`` and its variant), else
        ``humber``.
    n_modes : int
        Retained modes.
    speed_max_m_s : float
        The design speed [m/s]: a failure is safe when its critical speed is above it.
    speeds : array, optional
        Sweep grid [m/s]; default ``0 .. 1.5 speed_max`` every 0.5 m/s (as
        :mod:`bridgeflap.design.assessment.harm`).
    stuck_angle_deg : float
        Angle [deg] of a pair stuck away from 0 (its static deflection; stability as stuck at 0).
    static_speeds_m_s : sequence, optional
        Speeds [m/s] of the static deflection; default :data:`STATIC_SPEED_FRACTIONS` of the
        design speed and 0.95 of the failed loop's static root when inside the grid.
    workers : int
        Processes for the sweeps (one per case).
    """
    from bridgeflap.model.aeroelastic.flaps import _main_span_frame, closed_loop_model
    from bridgeflap.model.structure.loader import load_bridge
    from bridgeflap.model.structure.spec import BridgeSpec

    if not (np.isfinite(speed_max_m_s) and speed_max_m_s > 0):
        raise BridgeflapInputError("speed_max_m_s", f"must be positive, got {speed_max_m_s}")
    if not (isinstance(stuck_angle_deg, (int, float)) and np.isfinite(stuck_angle_deg)
            and abs(stuck_angle_deg) <= 90.0):
        raise BridgeflapInputError("stuck_angle_deg",
                                   f"must be a number in [-90, 90], got {stuck_angle_deg!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BridgeflapInputError("workers", f"must be an integer >= 1, got {workers!r}")
    if bridge is None:
        rec = controller.plant
        bridge = ("humber" if rec is None else
                  rec.bridge + (f":{rec.bridge_variant}" if rec.bridge_variant else ""))
    spec = bridge if isinstance(bridge, BridgeSpec) else load_bridge(bridge)
    name = spec.name if isinstance(bridge, BridgeSpec) else str(bridge)
    u = (np.arange(0.0, 1.5 * speed_max_m_s + 1e-9, 0.5) if speeds is None
         else np.asarray(speeds, dtype=float))
    grid_max = float(u[-1])
    say = progress or (lambda msg: None)
    model = closed_loop_model(spec, controller.flap_strip_positions_m, controller.flap_width_m,
                              int(n_modes), controller.chord_m, controller.leading_edge,
                              controller.trailing_edge)
    k, n_f = controller.compensator, model.n_flaps
    jobs = [("intact", np.ones(n_f)), ("open_loop", None), ("controller_off", np.zeros(n_f))]
    for f in range(n_f):
        w = np.ones(n_f)
        w[f] = 0.0
        jobs.append((f, w))
    say(f"fail-safe: {n_f} pairs + intact, open loop, controller off ({n_modes} modes, "
        f"0..{grid_max:g} m/s)")
    eta, every = Eta(len(jobs)), max(1, len(jobs) // 10)

    def tick(i):  # a line at every tenth of the sweeps, with the time left
        if (i + 1) % every == 0 or i + 1 == len(jobs):
            say(f"fail-safe: {i + 1}/{len(jobs)} sweeps {eta.text(i + 1)}")

    out = []
    if workers == 1:
        for i, (_, w) in enumerate(jobs):
            out.append(_case(model, k, w, u, sweep_method, grid_max))
            tick(i)
    else:
        from bridgeflap.model.workers import process_pool

        with process_pool(workers) as ex:
            futs = [ex.submit(_case, model, k, w, u, sweep_method, grid_max) for _, w in jobs]
            for i, f in enumerate(futs):
                out.append(f.result())
                tick(i)
    cases = {label: _stability(s, st, grid_max, speed_max_m_s)
             for (label, _), (s, st) in zip(jobs, out, strict=True)}
    intact, ol = cases["intact"], cases["open_loop"]
    mid_x, _ = _main_span_frame(spec)
    edges = _edges(controller)
    rows, stuck = [], []
    angle = math.radians(float(stuck_angle_deg))
    for f in range(n_f):
        c = cases[f]
        root = c["divergence_static_root_m_s"]
        sp = ([float(s) for s in static_speeds_m_s] if static_speeds_m_s is not None else
              [x * speed_max_m_s for x in STATIC_SPEED_FRACTIONS]
              + ([0.95 * root] if np.isfinite(root) and root <= grid_max else []))
        resp = _stuck_response(model, k, f, angle, sp, mid_x)
        stuck.extend(resp)
        at = min(resp, key=lambda r: abs(r["speed_m_s"] - speed_max_m_s))
        rows.append({"pair": f, "position_m": float(controller.flap_strip_positions_m[f]),
                     "edges": edges, "failure": "stuck at 0 (or at a fixed angle: the same "
                     "linear stability)", **c,
                     "over_intact": _ratio(c["critical_speed_m_s"],
                                           intact["critical_speed_m_s"]),
                     "over_open_loop": _ratio(c["critical_speed_m_s"],
                                              ol["critical_speed_m_s"]),
                     "lower_than_intact": bool(
                         c["critical_speed_m_s"] is not None
                         and (intact["critical_speed_m_s"] is None
                              or c["critical_speed_m_s"] < intact["critical_speed_m_s"])),
                     "stuck_speed_m_s": at["speed_m_s"],
                     "stuck_twist_max_abs_deg": at["twist_max_abs_deg"],
                     "stuck_heave_max_abs_m": at["heave_max_abs_m"]})
    say(f"fail-safe: done ({len(rows)} pairs)")
    off = cases["controller_off"]
    off = {**off, "over_intact": _ratio(off["critical_speed_m_s"],
                                        intact["critical_speed_m_s"])}
    return FailSafeResult(bridge=str(name), n_modes=int(n_modes),
                          speed_max_m_s=float(speed_max_m_s), speeds_max_m_s=grid_max,
                          stuck_angle_deg=float(stuck_angle_deg), edges=edges, intact=intact,
                          open_loop=ol, controller_off=off, rows=tuple(rows),
                          stuck_response=tuple(stuck))
