"""Benchmark: Humber compensator design solves (``python -m bench.design [--json]``).

For each (retained modes, design step) pair, one Ipopt solve (robust epigraph on, no cutting
planes) from the same start: build time, wall time, Ipopt iterations, time per eigenvalue
constraint evaluation (one ``eig`` with left/right vectors at one speed; the Jacobian reuses
it), time of one robust-constraint evaluation and its Jacobian (all points), and the dense
check on the same model; the optimiser's gamma_T (Frobenius bound at the sample points) against
the dense sigma_max peak of T at the robust check speeds (the robust cutting-plane test) and
the time of that dense check.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def run(modes=(8, 12, 16), steps=(10.0, 5.0)) -> list[dict]:
    """Time one solve per (modes, design step) pair."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    import casadi as ca

    from design.driver import build_model
    from design.nlp import DesignProblem
    from design.settings import load_settings

    rows = []
    th = np.array([0.0, 0.5, -1.0, 0.05, 0.5])
    for nm in modes:
        for step in steps:
            s = load_settings(n_modes=nm, design_step_m_s=step, starts=1)
            t0 = time.perf_counter()
            _, model = build_model(s)
            prob = DesignProblem(s, model)
            fun, pts = prob.robust_function()
            build = time.perf_counter() - t0
            w = np.ones(model.n_flaps)
            t1 = time.perf_counter()
            fun(th, w)
            rob_eval = time.perf_counter() - t1
            x = ca.MX.sym("x", 5)
            jf = ca.Function("J", [x], [ca.jacobian(fun(x, w), x)])
            t1 = time.perf_counter()
            jf(th)
            rob_jac = time.perf_counter() - t1
            res = prob.solve(th, s.design_speeds())
            t1 = time.perf_counter()
            ver = prob.verify(res.theta)
            verify_s = time.perf_counter() - t1
            t1 = time.perf_counter()
            rm = prob.robust_margin(res.theta, speeds=prob.robust_check_speeds())
            dense_s = time.perf_counter() - t1
            rows.append({"n_modes": nm, "n_states": int(prob.A_parts(th)[0].shape[0]),
                         "design_speeds": len(s.design_speeds()),
                         "robust_points": len(pts), "build_s": round(build, 3),
                         "solve_s": round(res.time_s, 2),
                         "ipopt_iterations": res.iterations, "ipopt_status": res.ipopt_status,
                         "eig_eval_per_speed_s": round(res.eig_time_per_speed_s, 4),
                         "eig_evaluations": res.eig_evaluations,
                         "robust_eval_s": round(rob_eval, 4), "robust_jac_s": round(rob_jac, 4),
                         "verify_s": round(verify_s, 2),
                         "gamma_T_frobenius": round(res.gamma_T, 4),
                         "dense_T_peak": round(rm.peak, 4),
                         "dense_T_check_s": round(dense_s, 2),
                         "max_violation_dense_1_s": ver.max_violation_1_s,
                         "stable_to_m_s": ver.stable_to_m_s})
    return rows


def main(argv=None) -> int:
    """Command-line entry."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    rows = run()
    if args.json:
        print(json.dumps({"design": rows}))
    else:
        keys = list(rows[0])
        print(" | ".join(keys))
        for r in rows:
            print(" | ".join(str(r[k]) for k in keys))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
