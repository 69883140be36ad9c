"""Benchmark of the buffeting analysis: ``python -m bench.buffeting [--json]``.

Humber, 16 modes, 4-25 m/s (22 speeds), seed inputs (Busch-Panofsky, Liepmann, sigma_w/U =
0.07, c from the bridge file). Times and accuracy of

* the numpy spectral path against the frequency-grid size (reference: 4x denser grid, twice
  the cluster width);
* the CasADi expression (:func:`bridgeflap.model.aeroelastic.symbolic.buffeting_rms_function`, build
  + evaluation) of the maximum-heave and maximum-pitch strips at every speed;
* Monte-Carlo at two speeds (independent check, with its standard error).

Set ``OPENBLAS_NUM_THREADS=1`` on shared machines.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from bridgeflap.model.aero.gust import gust_field
from bridgeflap.model.aeroelastic.symbolic import buffeting_rms_function, build_symbolic
from bridgeflap.model.analysis import bridge_system
from bridgeflap.model.response.buffeting import buffeting
from bridgeflap.model.structure.loader import load_bridge

SPEEDS = np.arange(4.0, 25.5, 1.0)
REFERENCE = {"n_base": 480, "peaks_per_mode": 161, "half_widths": 60.0}
GRIDS = ((30, 11), (60, 21), (120, 41), (240, 81))  # (n_base, peaks_per_mode); default 120/41
MC_SPEEDS = (10.0, 20.0)


def run(quick: bool = False) -> dict:
    """Run the benchmark and return a JSON-ready dict."""
    spec = load_bridge("humber")
    t0 = time.perf_counter()
    _, system = bridge_system(spec, 16)
    t_build = time.perf_counter() - t0
    ref = buffeting(system, SPEEDS, spec=spec, **REFERENCE)
    rows = []
    for n_base, peaks in GRIDS:
        t = time.perf_counter()
        r = buffeting(system, SPEEDS, spec=spec, n_base=n_base, peaks_per_mode=peaks)
        dt = time.perf_counter() - t
        ratio_v = r.rms_vertical / ref.rms_vertical
        ratio_t = r.rms_torsion / ref.rms_torsion
        rows.append({"path": "numpy", "n_base": n_base, "peaks_per_mode": peaks,
                     "grid_points_mean": float(np.mean(r.grid_points)), "time_s": dt,
                     "max_abs_ratio_error_vertical": float(np.max(np.abs(ratio_v - 1))),
                     "max_abs_ratio_error_torsion": float(np.max(np.abs(ratio_t - 1))),
                     "max_convergence_estimate": float(np.max(r.convergence)),
                     "statuses": sorted(set(r.status))})
    # end-to-end (spec -> result, including the modal model) at the default grid
    t = time.perf_counter()
    default = buffeting(spec, SPEEDS)
    t_end_to_end = time.perf_counter() - t

    # CasADi path (coarser fixed grid, one 2n x 2n dense solve per frequency)
    g = gust_field(spec)
    ns = system.basis.n_strip
    sm = build_symbolic(spec, system.basis.n)
    p0 = np.ones(len(sm.parameters))
    cas_v, cas_t, np_same = [], [], []
    t_cas_build = t_cas_eval = 0.0
    speeds_cas = SPEEDS[::7] if quick else SPEEDS
    for i, U in enumerate(SPEEDS):
        if U not in speeds_cas:
            continue
        jv = int(np.argmax(np.where(default.main_span, default.rms_heave[i], -np.inf)))
        jt = int(np.argmax(np.where(default.main_span, default.rms_pitch[i], -np.inf)))
        t = time.perf_counter()
        fun, _ = buffeting_rms_function(sm.A_fun, sm.B_fun, [p0], system.C_out,
                                        system.basis.strip_x, U, g, [jv, ns + jt])
        t_cas_build += time.perf_counter() - t
        t = time.perf_counter()
        val = np.array(fun(p0)).ravel()
        t_cas_eval += time.perf_counter() - t
        cas_v.append(val[0] / ref.rms_heave[i, jv])
        cas_t.append(val[1] / ref.rms_pitch[i, jt])
        np_same.append(val[0] / default.rms_heave[i, jv])
    rows.append({"path": "casadi", "speeds": len(cas_v), "build_time_s": t_cas_build,
                 "eval_time_s": t_cas_eval, "time_s": t_cas_build + t_cas_eval,
                 "max_abs_ratio_error_vertical": float(np.max(np.abs(np.array(cas_v) - 1))),
                 "max_abs_ratio_error_torsion": float(np.max(np.abs(np.array(cas_t) - 1)))})

    mc_rows = []
    for U in (MC_SPEEDS[:1] if quick else MC_SPEEDS):
        t = time.perf_counter()
        mc = buffeting(system, [U], spec=spec, method="monte-carlo", mc_records=16, mc_seed=1)
        dt = time.perf_counter() - t
        i = int(np.argmin(np.abs(SPEEDS - U)))
        mc_rows.append({"speed_m_s": U, "time_s": dt, "rms_vertical_m": mc.rms_vertical[0],
                        "standard_error_m": mc.standard_error_vertical[0],
                        "ratio_to_reference": mc.rms_vertical[0] / ref.rms_vertical[i],
                        "z_score": (mc.rms_vertical[0] - ref.rms_vertical[i])
                        / mc.standard_error_vertical[0],
                        "synthesis_points": int(mc.grid_points[0])})
    return {"bridge": "humber", "modes": 16, "states": system.n_states, "strips": ns,
            "speeds_m_s": SPEEDS.tolist(), "system_build_s": t_build,
            "end_to_end_default_s": t_end_to_end, "reference_grid": REFERENCE,
            "reference_rms_vertical_over_width": ref.rms_vertical_over_width.tolist(),
            "spectral": rows, "monte_carlo": mc_rows}


def _table(res: dict) -> str:
    out = [f"Humber, {res['modes']} modes ({res['states']} states, {res['strips']} strips), "
           f"22 speeds 4-25 m/s; system build {res['system_build_s']:.2f} s; "
           f"end-to-end default {res['end_to_end_default_s']:.2f} s",
           f"{'path':7s} {'grid':>10s} {'pts':>7s} {'time [s]':>9s} {'max|r_z-1|':>11s} "
           f"{'max|r_a-1|':>11s} {'conv est':>9s}"]
    for r in res["spectral"]:
        if r["path"] == "numpy":
            out.append(f"{'numpy':7s} {r['n_base']:>4d}/{r['peaks_per_mode']:<5d} "
                       f"{r['grid_points_mean']:7.0f} {r['time_s']:9.3f} "
                       f"{r['max_abs_ratio_error_vertical']:11.2e} "
                       f"{r['max_abs_ratio_error_torsion']:11.2e} "
                       f"{r['max_convergence_estimate']:9.2e}")
        else:
            out.append(f"{'casadi':7s} {'40/15':>10s} {'':>7s} {r['time_s']:9.3f} "
                       f"{r['max_abs_ratio_error_vertical']:11.2e} "
                       f"{r['max_abs_ratio_error_torsion']:11.2e}   "
                       f"(build {r['build_time_s']:.2f} s, eval {r['eval_time_s']:.2f} s, "
                       f"{r['speeds']} speeds)")
    out.append("ratios r are against the reference grid " + json.dumps(res["reference_grid"]))
    for m in res["monte_carlo"]:
        out.append(f"monte-carlo U = {m['speed_m_s']:g} m/s: ratio {m['ratio_to_reference']:.4f}"
                   f" (SE {m['standard_error_m'] / m['rms_vertical_m']:.2%}, z = "
                   f"{m['z_score']:+.2f}), {m['time_s']:.2f} s")
    return "\n".join(out)


def main(argv=None) -> int:
    """Command-line entry point."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quick", action="store_true", help="fewer CasADi and Monte-Carlo speeds")
    args = p.parse_args(argv)
    res = run(args.quick)
    if args.json:
        sys.stdout.write(json.dumps(res, default=float) + "\n")
    else:
        sys.stdout.write(_table(res) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
