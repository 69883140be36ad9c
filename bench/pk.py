"""Bench: the p-k flutter speed, fast against reference, RFA state space and (optional) wawi.

Run ``python -m bench.pk`` (a table) or ``python -m bench.pk --json`` (one JSON object), with
``OPENBLAS_NUM_THREADS=1`` on a shared machine. Per case, best of ``--repeat`` (default 5):

* ``fast p-k``: :func:`bridgeflap.model.stability.sweeps.pk_sweep` as the CLI calls it (the lean
  kernel of
  :mod:`bridgeflap.model.stability.pk_kernel`, branches marched speed by speed and stopped at the
  first crossing);
* ``reference p-k``: the same with ``full_grid=True`` (the whole grid, fixed-point k iteration
  on the frozen system's own matrices), best of ``--reference-repeat`` (default 1: it is slow);
* ``rfa eigen``: :func:`bridgeflap.model.stability.sweeps.sweep` on the RFA state space of the same
  case;
* ``wawi``: wawi's ``itflutter_cont_naive`` (optional, below), best of ``--repeat`` in its
  own process.

Cases (``--cases``): the IABSE TG3.1 sections ``iabse-1.1a`` (flat plate) and ``iabse-1.1c``
(PoliMi tables) on their CLI grid (:func:`bridgeflap.model.cases.section_cases.default_speeds`, 0 to
twice the reference speed in 401 points), the 12-mode step-2a bridges ``iabse-2a`` (flat plate) and
``iabse-2a:bb3`` (BB3 tables) on 0:100:0.5 [m/s], and on request ``humber`` (no wawi input,
slow: its reference p-k takes about a minute) with the ``flutter --pk`` defaults
(:func:`bridgeflap.model.analysis.pk_flutter`: 30 modes, 0:85:0.5). ``--speed-tol`` (default 1e-3
m/s, the CLI's and wawi's tolerance) is bridgeflap's refinement tolerance. The system
build (fit, modes) is outside the timings, as wawi's is. The header gives the CPU count, the
BLAS threads and the load average (the machine is shared: the best of several runs is the
figure to quote).

wawi (https://github.com/knutankv/wawi, MIT) is optional and lives in its own virtual
environment, because its dependency set (pyvista, trame, jupyter...) is far larger than
bridgeflap's::

    python -m venv /tmp/wawi-venv && /tmp/wawi-venv/bin/pip install wawi
    PYTHONPATH=. python -m bench.pk [--wawi-python /tmp/wawi-venv/bin/python]

Both codes get the same inputs from ``model/bridges/iabse/`` (masses, stiffnesses, 0.3 %
damping, B = 31 m, rho = 1.22): wawi's ``itflutter_cont_naive`` (the call of its
``tests/test_IABSE_step11a.py``: V = 0.1, dV = 5, tol 1e-3 m/s) with its own ``flatplate_ads``
for 1.1a, and for 1.1c derivative functions built in the wawi process from the shipped PoliMi
CSV (linear ``interp1d`` in ``v = U/(B omega)``, end values held, the conversion of
:func:`bridgeflap.model.aero.derivatives.polimi_to_scanlan`): no pickle is loaded. Step 2a
(``iabse-2a``, flat plate; ``iabse-2a:bb3``, the BB3 tables of ``step2a_bb3_derivatives.json`` with
the conversion that file states and the sign flips of wawi's ``tests/test_IABSE_step2a.py``): the
12 modes of ``step2a_modes.json`` at their 71 nodes (wawi integrates by the trapezoid rule over
the nodes, bridgeflap over its 12 m strips). wawi 0.0.19 calls ``np.trapz``, which numpy 2.4
(what its unpinned requirements install) removed: the wawi process aliases it to
``np.trapezoid``. Timings are informative only (a bench is never a unit test).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

WAWI_SCRIPT = r"""
import json, sys, time
import numpy as np
from scipy.interpolate import interp1d
if not hasattr(np, "trapz"):  # wawi 0.0.19 calls np.trapz, removed in numpy 2.4 (unpinned)
    np.trapz = np.trapezoid
from wawi.wind import flatplate_ads, itflutter_cont_naive

case = json.loads(sys.stdin.read())
m = np.array(case["m"]); k = np.array(case["k"]); zeta = case["zeta"]
n = m.size
Ms, Ks = np.diag(m), np.diag(k)
Cs = np.diag(2 * zeta * np.sqrt(k * m))
if "x" in case:  # a modal model: (y, z, theta_x) shapes at the deck nodes (IABSE step 2a)
    x = np.array(case["x"])
    phi = np.zeros((6 * x.size, n))
    for d, key in ((1, "y"), (2, "z"), (3, "theta_x")):
        phi[d::6, :] = np.array(case[key])
else:
    # wawi's phi: 6 DOFs (x, y, z, rx, ry, rz) per point, two points one metre apart (trapz = 1)
    x = np.array([0.0, 1.0])
    dof = {"lateral": 1, "heave": 2, "pitch": 3}
    phi = np.zeros((12, n))
    for j, lab in enumerate(case["dofs"]):
        phi[dof[lab], j] = phi[6 + dof[lab], j] = 1.0
if case["kind"] == "flat-plate":
    ads = flatplate_ads()
elif case["kind"] == "bb3":
    # tests/test_IABSE_step2a.py of wawi: the BB3 PoliMi tables, per-column abscissae, converted
    # as the file states, then that test's sign flips (A1, A4, A5, A6, H2, H3, P2, P3)
    ax = {key: np.array(case[key]) for key in ("v_heave", "v_pitch")}
    col = [ax[a] for a in case["abscissa_of_column"]]
    tab = {f: np.array(case[f]) for f in "hap"}
    fi = {fam: [interp1d(ax["v_pitch"] if fam == "p" else col[i], tab[fam][:, i],
                         kind="linear", bounds_error=False,
                         fill_value=(tab[fam][0, i], tab[fam][-1, i])) for i in range(6)]
          for fam in "hap"}
    fac = [lambda x: -x, lambda x: -x, lambda x: x * x, lambda x: np.pi / 2 + 0 * x,
           lambda x: -x, lambda x: 1 + 0 * x]
    one = lambda x: 1 + 0 * x
    flips = {"A1", "A4", "A5", "A6", "H2", "H3", "P2", "P3"}
    ads = {}
    def make(f, c, sgn):
        return lambda v: sgn * c(v) * f(v)
    for fam, key in (("h", "H"), ("a", "A")):
        for i in range(6):
            nm = f"{key}{i + 1}"
            ads[nm] = make(fi[fam][i], fac[i], -1.0 if nm in flips else 1.0)
    pm = {1: (4, fac[0]), 2: (1, fac[1]), 3: (2, fac[2]), 4: (3, one), 5: (0, fac[0]),
          6: (5, one)}  # P_i = c * p_j: P1 = -v p5, P2 = -v p2, P3 = v^2 p3, P4 = p4, P5 = -v p1
    for i, (j, c) in pm.items():
        nm = f"P{i}"
        ads[nm] = make(fi["p"][j], c, -1.0 if nm in flips else 1.0)
else:
    v = np.array(case["v"]); tab = {f: np.array(case[f]) for f in "hap"}
    f = {fam: [interp1d(v, tab[fam][:, i], kind="linear", bounds_error=False,
                        fill_value=(tab[fam][0, i], tab[fam][-1, i])) for i in range(6)]
         for fam in "hap"}
    fac = [lambda x: -x, lambda x: -x, lambda x: x * x, lambda x: np.pi / 2 + 0 * x,
           lambda x: -x, lambda x: np.pi / 2 + 0 * x]
    ads = {}
    for fam, key in (("h", "H"), ("a", "A")):
        for i in range(6):
            ads[f"{key}{i + 1}"] = (lambda fi, ci: (lambda x: ci(x) * fi(x)))(f[fam][i], fac[i])
    pm = {1: (4, 0), 2: (1, 1), 3: (2, 2), 4: (5, 3), 5: (0, 4), 6: (3, 5)}  # P_i: (p idx, fac)
    for i, (pi, ci) in pm.items():
        ads[f"P{i}"] = (lambda fi, cf: (lambda x: cf(x) * fi(x)))(f["p"][pi], fac[ci])
dt = float("inf")
for _ in range(case.get("repeat", 1)):
    t = time.perf_counter()
    res = itflutter_cont_naive(Ms, Cs, Ks, phi, x, ads, case["B"], V=0.1,
                               rho=case["rho"], dV=5, overshoot_factor=0.5, itmax={}, tol={},
                               print_progress=False)
    dt = min(dt, time.perf_counter() - t)
lam = res["lambd"][-1][res["critical_mode"][-1]]
print(json.dumps({"speed_m_s": float(res["V"][-1]),
                  "frequency_hz": float(abs(lam.imag) / 2 / np.pi), "time_s": dt}))
"""


def _case_input(case) -> dict:
    import csv
    import io
    from importlib import resources

    d = json.loads(resources.files("bridgeflap.model.bridges").joinpath(
        "iabse", f"{case.name}.json").read_text("utf-8"))
    out = {"m": d["mass_kg_per_m"], "k": d["stiffness_n_per_m2"], "zeta": d["damping_ratio"],
           "dofs": d["dofs"], "B": d["chord_m"], "rho": d["air_density_kg_m3"],
           "kind": d["derivatives"]["kind"]}
    if out["kind"] == "polimi-table":
        text = resources.files("bridgeflap.model.bridges").joinpath(
            "iabse", d["derivatives"]["file"]).read_text("utf-8")
        rows = list(csv.DictReader(io.StringIO(
            "\n".join(s for s in text.splitlines() if not s.startswith("#")))))
        out["v"] = [float(r["v_omega"]) for r in rows]
        for f in "hap":
            out[f] = [[float(r[f"{f}{i}"]) for i in range(1, 7)] for r in rows]
    return out


#: modal (full-bridge) cases: built-in bridge names of the IABSE step-2a model
MODAL_CASES = {"iabse-2a": 69.8, "iabse-2a:bb3": 69.8}


def _modal_case_input(spec) -> dict:
    """wawi's inputs for a modal bridge: the file's nodes and (y, z, theta_x) shapes as read
    (step2a_modes.json: z up, theta_x and y of wawi's frame), m, k, 0.3 % damping."""
    raw = json.loads(Path(spec.structure.file).read_text("utf-8"))
    out = {"m": raw["generalised_mass"], "k": raw["provenance"]["modal_stiffness_k"],
           "zeta": float(raw["damping_ratio"][0]), "x": raw["station_x"],
           "y": raw["lateral"], "z": raw["vertical"], "theta_x": raw["torsional"],
           "B": 2 * spec.deck.half_chord_m, "rho": spec.aero.air_density_kg_m3,
           "kind": "flat-plate"}
    if len(set(raw["damping_ratio"])) != 1:
        raise ValueError("the bench assumes one damping ratio for all modes")
    if spec.derivatives is not None:
        d = json.loads(Path(spec.derivatives.file).read_text("utf-8"))
        out.update(kind="bb3", v_heave=d["v_heave"], v_pitch=d["v_pitch"],
                   abscissa_of_column=d["abscissa_of_column"], **d["polimi"])
    return out




def _blas_threads() -> str:
    try:
        from threadpoolctl import threadpool_info

        return ", ".join(f"{i['internal_api']}={i['num_threads']}" for i in threadpool_info()
                         if i.get("user_api") == "blas") or "unknown"
    except ImportError:  # pragma: no cover
        return "unknown"


def _best(fn, repeat: int):
    """(result, best wall time [s]) of ``fn()`` over ``repeat`` runs."""
    best, out = float("inf"), None
    for _ in range(max(1, int(repeat))):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def _case_system(name: str):
    """``(system, speeds [m/s], wawi input or None, reference speed [m/s])`` of a case."""
    from bridgeflap.model.aeroelastic.derivative_system import derivative_system
    from bridgeflap.model.analysis import bridge_system
    from bridgeflap.model.cases.section_cases import case_fit, default_speeds, load_section_case
    from bridgeflap.model.structure.loader import load_bridge

    if name in MODAL_CASES:
        spec = load_bridge(name)
        _, system = bridge_system(spec, 30)
        return system, np.arange(0.0, 100.01, 0.5), _modal_case_input(spec), MODAL_CASES[name]
    if name == "humber":
        from bridgeflap.design.io.options import parse_range
        from bridgeflap.design.studies.analyses import DEFAULT_SPEEDS
        from bridgeflap.model.analysis import DEFAULT_MODES

        _, system = bridge_system(load_bridge("humber"), DEFAULT_MODES)
        return system, parse_range(DEFAULT_SPEEDS, "speeds", 0.0), None, float("nan")
    case = load_section_case(name)
    system = derivative_system(case.basis, case.derivatives, case.air_density,
                               fit=case_fit(case), phi_p=case.phi_p)
    return system, default_speeds(case), _case_input(case), case.reference_speed_m_s


def _row(method, speed, freq, status, time_s):
    return {"method": method, "flutter_speed_m_s": speed, "flutter_frequency_hz": freq,
            "flutter_status": status, "time_s": time_s}


def _wawi(python: str, wawi_input: dict, repeat: int):
    proc = subprocess.run([python, "-c", WAWI_SCRIPT],
                          input=json.dumps({**wawi_input, "repeat": int(repeat)}),
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": ""},
                          check=False)
    if proc.returncode != 0:
        return None, (proc.stderr.strip().splitlines() or ["no output"])[-1]
    w = json.loads(proc.stdout.strip().splitlines()[-1])
    return _row("wawi", w["speed_m_s"], w["frequency_hz"], "", w["time_s"]), ""


def run_case(name: str, repeat: int, reference_repeat: int, wawi_python: str | None,
             speed_tol: float = 1e-3) -> dict:
    """Rows and ratios of one case (module docstring)."""
    from bridgeflap.model.stability import sweeps as stability

    system, speeds, wawi_input, ref = _case_system(name)
    fast, t_fast = _best(lambda: stability.pk_sweep(system, speeds, speed_tol), repeat)
    full, t_full = _best(lambda: stability.pk_sweep(system, speeds, speed_tol, full_grid=True),
                         reference_repeat)
    rfa, t_rfa = _best(lambda: stability.sweep(system, speeds, speed_tol=speed_tol), repeat)
    rows = [_row("fast p-k", fast.flutter.speed, fast.flutter.frequency_hz, fast.flutter.status,
                 t_fast),
            _row("reference p-k", full.flutter.speed, full.flutter.frequency_hz,
                 full.flutter.status, t_full),
            _row("rfa eigen", rfa.flutter.speed, rfa.flutter.frequency_hz, rfa.flutter.status,
                 t_rfa)]
    out = {"case": name, "reference_flutter_speed_m_s": ref, "n_speeds": int(len(speeds)),
           "n_states": int(system.n_states), "pk_states": int(2 * system.basis.n),
           "rows": rows,
           "fast_minus_reference_speed_m_s": fast.flutter.speed - full.flutter.speed,
           "reference_over_fast_time": t_full / t_fast}
    if wawi_python and wawi_input is not None:
        w, err = _wawi(wawi_python, wawi_input, repeat)
        if w is None:
            out["wawi_error"] = err
        else:
            rows.append(w)
            out["fast_minus_wawi_speed_m_s"] = fast.flutter.speed - w["flutter_speed_m_s"]
            out["wawi_over_fast_time"] = w["time_s"] / t_fast
    return out


def _clean(x):
    """NaN and inf as None (strict JSON)."""
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--wawi-python", default="/tmp/wawi-venv/bin/python",
                   help="interpreter of wawi's venv; 'none' to skip wawi")
    p.add_argument("--cases", default="iabse-1.1a,iabse-1.1c,iabse-2a,iabse-2a:bb3",
                   help="comma-separated; 'humber' (30 modes) is slow: about a minute")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--reference-repeat", type=int, default=1)
    p.add_argument("--speed-tol", type=float, default=1e-3,
                   help="refinement tolerance [m/s] of bridgeflap's crossings (1e-3: the CLI's "
                        "and wawi's)")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    wawi = args.wawi_python if args.wawi_python != "none" and Path(args.wawi_python).exists() \
        else None
    header = {"cpu_count": os.cpu_count(), "blas_threads": _blas_threads(),
              "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
              "load_average_1_5_15": list(os.getloadavg()), "repeat": args.repeat,
              "reference_repeat": args.reference_repeat, "wawi": bool(wawi),
              "speed_tol_m_s": args.speed_tol}
    if not args.json:
        print(f"CPUs: {header['cpu_count']}; BLAS threads: {header['blas_threads']}; "
              f"OPENBLAS_NUM_THREADS={header['openblas_num_threads']}; load average "
              f"{', '.join(f'{x:.2f}' for x in header['load_average_1_5_15'])}; best of "
              f"{args.repeat} (reference p-k: {args.reference_repeat})"
              + ("" if wawi else f"; wawi not found ({args.wawi_python})"))
    cases = []
    for name in args.cases.split(","):
        c = run_case(name, args.repeat, args.reference_repeat, wawi, args.speed_tol)
        cases.append(c)
        if args.json:
            continue
        print(f"\n{name} ({c['n_speeds']} speeds, p-k on {c['pk_states']} states, RFA "
              f"{c['n_states']} states; reference {c['reference_flutter_speed_m_s']:g} m/s)")
        for r in c["rows"]:
            print(f"  {r['method']:14s} {r['flutter_speed_m_s']:10.4f} m/s  "
                  f"{r['flutter_frequency_hz']:.5f} Hz  {r['time_s'] * 1e3:9.1f} ms  "
                  f"{r['flutter_status']}")
        line = (f"  fast - reference {c['fast_minus_reference_speed_m_s']:+.1e} m/s, "
                f"reference / fast time {c['reference_over_fast_time']:.1f}")
        if "wawi_over_fast_time" in c:
            line += (f"; fast - wawi {c['fast_minus_wawi_speed_m_s']:+.1e} m/s, wawi / fast "
                     f"time {c['wawi_over_fast_time']:.2f}")
        elif "wawi_error" in c:
            line += f"; wawi failed: {c['wawi_error']}"
        print(line)
    header["load_average_after_1_5_15"] = list(os.getloadavg())
    if args.json:
        print(json.dumps(_clean({**header, "cases": cases}), allow_nan=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
