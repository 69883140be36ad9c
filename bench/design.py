"""Benchmark: one Humber compensator design solve (``python -m bench.design [--json]``).

Reports wall time, Ipopt iterations and time per constraint evaluation (eig + Jacobian at one
speed) against the number of design speeds and retained modes.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def run(modes=(8, 12), steps=(10.0, 5.0)) -> list[dict]:
    """Time one solve per (modes, design step) pair."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from design.problem import DesignProblem, _build_model, load_settings

    rows = []
    for nm in modes:
        for step in steps:
            s = load_settings(n_modes=nm, design_step_m_s=step, starts=1)
            t0 = time.perf_counter()
            _, model = _build_model(s)
            prob = DesignProblem(s, model)
            build = time.perf_counter() - t0
            th = np.array([0.0, 0.5, -1.0, 0.05, 0.5])
            cb = prob.callback(40.0)
            t1 = time.perf_counter()
            for _ in range(5):
                cb._cache_key = None
                cb(th)
                cb.jacobian(th + 1e-9 * np.random.default_rng(0).random(5))
            per_eval = (time.perf_counter() - t1) / 5
            res = prob.solve(th, s.design_speeds())
            ver = prob.verify(res["theta"])
            rows.append({"n_modes": nm, "n_states": int(prob.A_parts(th)[0].shape[0]),
                         "design_speeds": len(s.design_speeds()), "build_s": build,
                         "solve_s": res["time_s"], "ipopt_iterations": res["iterations"],
                         "ipopt_status": res["status"], "constraint_eval_s": per_eval,
                         "max_violation_dense_1_s": ver["max_violation"],
                         "stable_to_m_s": ver["stable_to_m_s"]})
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
        for r in rows:
            print(r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
