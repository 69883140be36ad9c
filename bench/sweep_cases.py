"""Cases and agreement of the dense and fast stability sweeps (:mod:`bench.stability`).

:func:`cases` builds the stated set (Humber open and closed loop, the IABSE cases, Great Belt
with the default and the bb3 flutter derivatives);
:func:`sampled_cases` draws bridges from Humber's estimated-input ranges
(:data:`bridgeflap.design.studies.screening.DEFAULT_UNCERTAIN_RANGES`) and erection stages;
:func:`compare` runs both methods on one case and says whether they agree: the same statuses and
labels, and the same flutter, divergence and second-flutter speeds to :data:`REL_TOL`.
"""

from __future__ import annotations

import time

import numpy as np

from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import DEFAULT_SPEEDS
from bridgeflap.model.stability import sweeps as stability

#: agreement of the fast and dense speeds, relative; the dense Brent tolerance is
#: 1e-3 m/s, 1.4e-5 of a 70 m/s flutter speed
REL_TOL = 1e-4

_SPEED_KEYS = ("flutter_speed_m_s", "divergence_speed_m_s", "second_flutter_speed_m_s")
_SAME_KEYS = ("flutter_status", "divergence_status", "second_flutter_status",
              "critical_branch_label", "divergence_branch_label", "second_critical_branch_label",
              "flutter_onset", "flutter_bracket_m_s", "divergence_bracket_m_s", "flutter_reason",
              "divergence_reason")  # the last four: only for a crossing seen but not converged

#: the closed-loop check's controller: nine 20 m flap pairs, K(s) = -1 / (0.1 s^2 + 0.5 s + 1)
#: (the one of tests/test_trust_stability.py)
_CONTROLLER = ((0.0, 0.0, -1.0, 0.1, 0.5), tuple(np.arange(-400.0, 401, 100)), 20.0)


def _bridge(name, n_modes, speeds=DEFAULT_SPEEDS, spec=None):
    from bridgeflap.model.analysis import bridge_system
    from bridgeflap.model.structure.loader import load_bridge

    _, system = bridge_system(spec if spec is not None else load_bridge(name), n_modes)
    return name, system, parse_range(speeds, "speeds", 0.0)


def _section(name):
    from bridgeflap.model.cases.section_cases import section_system

    return (name, *section_system(name))


def _closed_loop(n_modes):
    from bridgeflap.model.aeroelastic.control import Compensator
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model
    from bridgeflap.model.structure.loader import load_bridge

    comp, pos, width = _CONTROLLER
    model = closed_loop_model(load_bridge("humber"), pos, width, n_modes)
    return "humber closed loop", model.system(Compensator(*comp)), \
        parse_range(DEFAULT_SPEEDS, "speeds", 0.0)


def cases(n_modes: int = 30):
    """``[(name, system, speeds)]`` of the stated set."""
    return [_bridge("humber", n_modes), _closed_loop(n_modes), _section("iabse-1.1a"),
            _section("iabse-1.1c"), _bridge("iabse-2a", n_modes),
            _bridge("iabse-2a:bb3", n_modes), _bridge("great-belt", n_modes, "0:150:0.5"),
            _bridge("great-belt:bb3", n_modes, "0:150:0.5")]


def sampled_params(n: int, seed: int = 16):
    """``n`` parameter sets: uniform over the estimated-input ranges (coherence decay, which
    enters buffeting only, left out); every third one also an erection stage, erected
    fraction uniform on (0.1, 1)."""
    from bridgeflap.design.studies.screening import DEFAULT_UNCERTAIN_RANGES

    rng = np.random.default_rng(seed)
    ranges = {k: v for k, v in DEFAULT_UNCERTAIN_RANGES.items() if k != "aero.coherence_decay"}
    out = []
    for i in range(n):
        p = {k: float(rng.uniform(*v)) for k, v in ranges.items()}
        if i % 3 == 2:
            p["erected_fraction"] = float(rng.uniform(0.1, 1.0))
        out.append(p)
    return out


def sampled_case(params, n_modes: int = 30):
    from bridgeflap.design.studies.cases import apply_parameters
    from bridgeflap.model.structure.loader import load_bridge

    spec = apply_parameters(load_bridge("humber"), params)
    return _bridge("humber sample", n_modes, spec=spec)


def _timed(fn, repeat):
    best, out = np.inf, None
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def _rel(a, b):
    if not (np.isfinite(a) or np.isfinite(b)):
        return 0.0
    if not (np.isfinite(a) and np.isfinite(b)):
        return np.inf
    return abs(a - b) / abs(b)


def compare(name, system, speeds, repeat: int = 1) -> dict:
    """Dense and fast sweep of one case: counts, times (best of ``repeat``), agreement."""
    dense, t_d = _timed(lambda: stability.sweep(system, speeds, method="dense"), repeat)
    fast, t_f = _timed(lambda: stability.sweep(system, speeds, method="fast"), repeat)
    sd, sf = dense.summary(), fast.summary()
    rel = max(_rel(sf[k], sd[k]) for k in _SPEED_KEYS)
    diff = [k for k in _SAME_KEYS if sd.get(k) != sf.get(k)]
    if rel > REL_TOL:
        diff.append(f"speeds differ by {rel:.2g} relative")
    return {"case": name, "states": int(system.n_states), "n_speeds": int(len(speeds)),
            "dense_eigen_solutions": sd["eigen_solutions"],
            "fast_eigen_solutions": sf["eigen_solutions"],
            "eigen_solution_ratio": sd["eigen_solutions"] / max(sf["eigen_solutions"], 1),
            "dense_s": t_d, "fast_s": t_f, "time_ratio": t_d / t_f,
            "fast_method": sf["sweep_method"], "fallback_reason": sf["sweep_fallback_reason"],
            "flutter_speed_m_s": sd["flutter_speed_m_s"],
            "fast_flutter_speed_m_s": sf["flutter_speed_m_s"],
            "divergence_speed_m_s": sd["divergence_speed_m_s"],
            "fast_divergence_speed_m_s": sf["divergence_speed_m_s"],
            "flutter_status": sd["flutter_status"], "divergence_status": sd["divergence_status"],
            "max_rel_speed_diff": rel, "agree": not diff, "differences": diff}
