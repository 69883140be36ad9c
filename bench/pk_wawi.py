"""Bench: wawi's p-k flutter against bridgeflap on the IABSE TG3.1 cases 1.1a, 1.1c and 2a.

Optional: needs wawi (https://github.com/knutankv/wawi, MIT) in its own virtual environment,
because its dependency set (pyvista, trame, jupyter...) is far larger than bridgeflap's::

    python -m venv /tmp/wawi-venv && /tmp/wawi-venv/bin/pip install wawi
    PYTHONPATH=. python bench/pk_wawi.py [--wawi-python /tmp/wawi-venv/bin/python]

Both codes get the same inputs from ``model/bridges/iabse/`` (masses, stiffnesses, 0.3 %
damping, B = 31 m, rho = 1.22): wawi's ``itflutter_cont_naive`` (the call of its
``tests/test_IABSE_step11a.py``: V = 0.1, dV = 5, tol 1e-3 m/s) with its own ``flatplate_ads``
for 1.1a, and for 1.1c derivative functions built in the wawi process from the shipped PoliMi
CSV (linear ``interp1d`` in ``v = U/(B omega)``, end values held, the conversion of
:func:`model.derivatives.polimi_to_scanlan`): no pickle is loaded. Step 2a (``iabse-2a``,
flat plate; ``iabse-2a:bb3``, the BB3 tables of ``step2a_bb3_derivatives.json`` with the
conversion that file states and the sign flips of wawi's ``tests/test_IABSE_step2a.py``): the
12 modes of ``step2a_modes.json`` at their 71 nodes (wawi integrates by the trapezoid rule over
the nodes, bridgeflap over its 12 m strips); bridgeflap runs ``model.analysis.bridge_system``
(the 4-lag Theodorsen RFA, or the 3-lag Roger RFA of the BB3 tables on all 12 modes with the
lateral DOF) and the p-k on the same system. bridgeflap: the exact p-k
(:func:`model.stability.pk_sweep` on :class:`model.derivatives.DerivativeFrozen`) and the
Roger-RFA eigenvalue sweep. wawi 0.0.19 calls ``np.trapz``, which numpy 2.4 (what its unpinned
requirements install) removed: the wawi process aliases it to ``np.trapezoid``. Prints
speeds, frequencies, wall times, their ratios, the CPU count
and the BLAS thread setting. Timings are informative only (a bench is never a unit test).
"""

from __future__ import annotations

import argparse
import json
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
t = time.perf_counter()
res = itflutter_cont_naive(Ms, Cs, Ks, phi, x, ads, case["B"], V=0.1,
                           rho=case["rho"], dV=5, overshoot_factor=0.5, itmax={}, tol={},
                           print_progress=False)
dt = time.perf_counter() - t
lam = res["lambd"][-1][res["critical_mode"][-1]]
print(json.dumps({"speed_m_s": float(res["V"][-1]),
                  "frequency_hz": float(abs(lam.imag) / 2 / np.pi), "time_s": dt}))
"""


def _case_input(case) -> dict:
    import csv
    import io
    from importlib import resources

    d = json.loads(resources.files("model.bridges").joinpath(
        "iabse", f"{case.name}.json").read_text("utf-8"))
    out = {"m": d["mass_kg_per_m"], "k": d["stiffness_n_per_m2"], "zeta": d["damping_ratio"],
           "dofs": d["dofs"], "B": d["chord_m"], "rho": d["air_density_kg_m3"],
           "kind": d["derivatives"]["kind"]}
    if out["kind"] == "polimi-table":
        text = resources.files("model.bridges").joinpath(
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


def _bridgeflap_modal(name: str, speeds):
    """bridgeflap on a modal bridge: (system, p-k, RFA sweep, build, p-k, sweep times)."""
    from model import stability
    from model.analysis import bridge_system
    from model.spec import load_bridge

    t = time.perf_counter()
    spec = load_bridge(name)
    _, system = bridge_system(spec, 30)
    t_build = time.perf_counter() - t
    t = time.perf_counter()
    pk = stability.pk_sweep(system, speeds[speeds > 0], speed_tol=1e-3)
    t_pk = time.perf_counter() - t
    t = time.perf_counter()
    sw = stability.sweep(system, speeds, speed_tol=1e-3)
    t_sw = time.perf_counter() - t
    return spec, system, pk, sw, t_build, t_pk, t_sw


def _blas_threads() -> str:
    try:
        from threadpoolctl import threadpool_info

        return ", ".join(f"{i['internal_api']}={i['num_threads']}" for i in threadpool_info()
                         if i.get("user_api") == "blas") or "unknown"
    except ImportError:  # pragma: no cover
        return "unknown"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--wawi-python", default="/tmp/wawi-venv/bin/python")
    p.add_argument("--cases", default="iabse-1.1a,iabse-1.1c,iabse-2a,iabse-2a:bb3")
    args = p.parse_args(argv)
    from model import stability
    from model.derivatives import derivative_system
    from model.section_cases import case_fit, load_section_case

    print(f"CPUs: {os.cpu_count()}; BLAS threads: {_blas_threads()}; "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    have_wawi = Path(args.wawi_python).exists()
    if not have_wawi:
        print(f"wawi interpreter not found ({args.wawi_python}): bridgeflap only")
    for name in args.cases.split(","):
        if name in MODAL_CASES:
            ref = MODAL_CASES[name]
            spec, system, pk, sw, t_build, t_pk, t_sw = _bridgeflap_modal(
                name, np.arange(0.0, 100.01, 0.5))
            fit_lags = system.rfa.n_lags if hasattr(system.rfa, "n_lags") else 4
            wawi_input = _modal_case_input(spec)
            print(f"\n{name} (12-mode modal model; reference {ref:g} m/s with the BB3 "
                  f"derivatives{'' if spec.derivatives else ', this is the flat plate'})")
        else:
            case = load_section_case(name)
            ref = case.reference_speed_m_s
            speeds = np.linspace(0.0, 2.0 * case.reference_speed_m_s, 201)
            t = time.perf_counter()
            fit = case_fit(case)
            system = derivative_system(case.basis, case.derivatives, case.air_density, fit=fit,
                                       phi_p=case.phi_p)
            t_build = time.perf_counter() - t
            t = time.perf_counter()
            pk = stability.pk_sweep(system, speeds, speed_tol=1e-3)
            t_pk = time.perf_counter() - t
            t = time.perf_counter()
            sw = stability.sweep(system, speeds, speed_tol=1e-3)
            t_sw = time.perf_counter() - t
            fit_lags = fit.n_lags
            wawi_input = _case_input(case)
            print(f"\n{name} (reference {ref:g} m/s)")
        print(f"  bridgeflap exact p-k : {pk.flutter.speed:8.3f} m/s  "
              f"{pk.flutter.frequency_hz:.4f} Hz  {t_pk:7.3f} s")
        print(f"  bridgeflap RFA sweep : {sw.flutter.speed:8.3f} m/s  "
              f"{sw.flutter.frequency_hz:.4f} Hz  {t_sw:7.3f} s (+ fit/build {t_build:.3f} s, "
              f"{fit_lags} lags, {system.n_states} states)")
        if not have_wawi:
            continue
        proc = subprocess.run([args.wawi_python, "-c", WAWI_SCRIPT],
                              input=json.dumps(wawi_input), capture_output=True,
                              text=True, env={**os.environ, "PYTHONPATH": ""}, check=False)
        if proc.returncode != 0:
            print("  wawi failed:", proc.stderr.strip().splitlines()[-1:])
            continue
        w = json.loads(proc.stdout.strip().splitlines()[-1])
        print(f"  wawi itflutter_naive : {w['speed_m_s']:8.3f} m/s  {w['frequency_hz']:.4f} Hz  "
              f"{w['time_s']:7.3f} s")
        print(f"  ratio bridgeflap p-k / wawi: speed {pk.flutter.speed / w['speed_m_s']:.5f}, "
              f"frequency {pk.flutter.frequency_hz / w['frequency_hz']:.5f}, "
              f"time {t_pk / w['time_s']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
