"""Benchmark: Humber compensator design (``python -m bench.design [--json] [--solves]``).

Default: the full default ``optimise`` (the packaged design definition, every start, cuts,
verification, closed-loop limits, buffeting comparison, then the acceptance checks with the
1000-variant do-no-harm validation on ``--workers`` processes) through
:func:`bridgeflap.design.assessment.accept.design`: wall time (design and checks apart, against the
120 s target), Ipopt iterations per start and round, and the share
of the wall time per phase (``DesignResult.extras["phase_times_s"]``; inside the starts, the
Ipopt share of each start; ``(worker)`` phases ran in worker processes alongside the others, so
the shares add up to more than 1), the CPU time of the process and its workers, the design's result
(max gain, optimiser's and verified robust margins, closed-loop flutter, minimum flap count),
the CPU count, the BLAS threads and the load (``uptime``) before and after. The machine is
shared by several agents: a best of several runs of a ~1-3 min design is not affordable there,
so one run is reported with its load; compare runs only at similar load (or by CPU time).

``--solves``: for each (retained modes, design step) pair, one Ipopt solve (robust epigraph on, no
cutting planes) from the same start: build time, wall time, Ipopt iterations, time per eigenvalue
constraint evaluation (one ``eig`` with left/right vectors at one speed; the Jacobian reuses it),
time of one robust-constraint evaluation and its Jacobian (all points), and the dense check on the
same model; the optimiser's gamma_T (Frobenius bound at the sample points) against the dense
sigma_max peak of T at the robust check speeds (the robust cutting-plane test) and the time of that
dense check.
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

    from bridgeflap.design.control.formulation.nlp import DesignProblem
    from bridgeflap.design.control.search.driver import build_model
    from bridgeflap.design.control.settings import load_settings

    rows = []
    th = np.array([0.0, 0.5, -1.0, 0.05, 0.5])
    for nm in modes:
        for step in steps:
            s = load_settings(None, n_modes=nm, design_step_m_s=step, starts=1)
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
                         "max_damping_violation_dense_1_s": ver.max_violation_1_s,
                         "stable_to_m_s": ver.stable_to_m_s})
    return rows


def _uptime() -> str:
    """``uptime`` output (load averages), or the 1/5/15-min load when it is missing."""
    import subprocess

    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, timeout=5,
                              check=False).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "load average: " + ", ".join(f"{v:.2f}" for v in os.getloadavg())


def _blas_threads():
    """BLAS thread counts (threadpoolctl when installed, else OPENBLAS_NUM_THREADS)."""
    try:
        from threadpoolctl import threadpool_info

        return {d.get("internal_api", "?"): d.get("num_threads") for d in threadpool_info()
                if d.get("user_api") == "blas"}
    except ImportError:
        return {"OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS")}


def _cpu_s() -> float:
    """CPU time [s] of this process and its finished children (the start and flap-count
    worker processes): on a shared machine a steadier measure than the wall time."""
    import resource

    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def run_full(definition=None, quick=False, checks="all", check_samples=None,
             check_workers=2) -> dict:
    """One full default design with its acceptance checks (the 1000-variant validation on
    ``check_workers`` processes): wall time, Ipopt iterations, share of time per phase."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from bridgeflap.design.assessment.accept import design
    from bridgeflap.design.cli.optimise import DEFAULT_DEFINITION
    from bridgeflap.design.control.settings import load_settings, quick_settings

    s = load_settings(definition or DEFAULT_DEFINITION)
    if quick:
        s = quick_settings(s)
    load0 = os.getloadavg()[0]
    up0 = _uptime()
    cpu0 = _cpu_s()
    t0 = time.perf_counter()
    res = design(s, progress_bar=False, checks=checks, check_samples=check_samples,
                 check_workers=check_workers, quick_checks=quick)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - cpu0
    phases = dict(res.extras.get("phase_times_s", {}))
    starts = []
    for st in res.starts:
        ipopt_s = sum(r.time_s for r in st.rounds)
        starts.append({"start": st.start, "status": st.ipopt_status,
                       "ipopt_iterations": st.iterations,
                       "rounds": [{"placement": r.placement, "round": r.round,
                                   "iterations": r.iterations, "time_s": round(r.time_s, 2),
                                   "variant_constraints": r.n_variant_constraints}
                                  for r in st.rounds],
                       "start_time_s": round(st.time_s, 2), "ipopt_time_s": round(ipopt_s, 2),
                       "ipopt_share_of_start": round(ipopt_s / st.time_s, 3)
                       if st.time_s else None,
                       "verified": st.verified, "robust_margin": st.robust_margin})
    best = res.best
    result = {} if best is None else {
        "compensator_b2_b1_b0_a2_a1": [round(float(v), 4) for v in best.theta],
        "chosen_start": best.start,
        "max_gain": best.max_gain, "robust_margin_optimiser": 1.0 / best.gamma_T_frobenius,
        "robust_margin_verified": best.robust_margin,
        "closed_loop_flutter_m_s": res.extras.get("closed_loop_limits", {}).get(
            "flutter_speed_m_s"),
        "closed_loop_critical_m_s": res.extras.get("closed_loop_limits", {}).get(
            "critical_speed_m_s"),
        "flap_count": len(best.flap_positions_m),
        "minimum_flaps": res.min_flaps.minimum if res.min_flaps else None,
        "flap_counts_checked": len(res.min_flaps.counts) if res.min_flaps else 0}
    acc = res.extras.get("acceptance") or {}
    checks_s = {k: round(v.get("elapsed_s", 0.0), 2) for k, v in acc.items()
                if isinstance(v, dict) and "elapsed_s" in v}
    rob = acc.get("robustness") or {}
    design_s = wall - sum(checks_s.values())
    return {"status": res.status, "wall_time_s": round(wall, 2),
            "design_wall_time_s": round(design_s, 2), "checks_wall_time_s": checks_s,
            "acceptance": {"status": acc.get("status"), "variants": rob.get("variants"),
                           "harmed": rob.get("harmed_count"),
                           "harm_probability_upper_95": rob.get("harm_probability_upper_95"),
                           "worst_closed_over_open": rob.get("worst_closed_over_open"),
                           "fraction_stable_to_design_speed":
                               rob.get("fraction_stable_to_design_speed"),
                           "unresolved": rob.get("unresolved_variants")},
            "check_workers": check_workers,
            "cpu_time_s": round(cpu, 2), "result": result,
            "cpu_count": os.cpu_count(), "blas_threads": _blas_threads(),
            "uptime_before": up0, "uptime_after": _uptime(),
            "target_wall_time_s": 120.0,
            "load_average_1min_before": round(load0, 2),
            "load_average_1min_after": round(os.getloadavg()[0], 2),
            "parallel_starts": bool(s.parallel and s.starts > 1),
            "ipopt_iterations_total": sum(st["ipopt_iterations"] for st in starts),
            "phase_share": {k: round(v / wall, 3) for k, v in phases.items()},
            "phase_time_s": {k: round(v, 2) for k, v in phases.items()},
            "starts": starts}


def main(argv=None) -> int:
    """Command-line entry."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", action="store_true")
    p.add_argument("--solves", action="store_true",
                   help="time single solves per (modes, design step) instead")
    p.add_argument("--quick", action="store_true", help="quick settings (full design only)")
    p.add_argument("--definition", default=None,
                   help="design definition .toml (full design; default: the packaged one)")
    p.add_argument("--checks", default="all",
                   help="acceptance checks after the design (all, none, or a comma list)")
    p.add_argument("--check-samples", dest="check_samples", type=int, default=None,
                   help="fresh variants of the validation (default 1000)")
    p.add_argument("--workers", type=int, default=2, help="processes of the checks")
    args = p.parse_args(argv)
    if not args.solves:
        out = run_full(args.definition, quick=args.quick, checks=args.checks,
                       check_samples=args.check_samples, check_workers=args.workers)
        if args.json:
            print(json.dumps({"design_full": out}))
        else:
            print(f"status {out['status']}, wall {out['wall_time_s']} s (target "
                  f"{out['target_wall_time_s']} s), Ipopt iterations "
                  f"{out['ipopt_iterations_total']}; {out['cpu_count']} CPUs, BLAS threads "
                  f"{out['blas_threads']}")
            print(f"  CPU {out['cpu_time_s']} s (this process and its workers); result "
                  f"{out['result']}")
            print(f"  design {out['design_wall_time_s']} s, checks {out['checks_wall_time_s']} "
                  f"({out['check_workers']} workers); acceptance {out['acceptance']}")
            print(f"  before: {out['uptime_before']}\n  after:  {out['uptime_after']}")
            for k, v in out["phase_time_s"].items():
                print(f"  {k}: {v} s ({100 * out['phase_share'][k]:.1f} %)")
            for st in out["starts"]:
                print(f"  start {st['start']}: {st['status']}, {st['ipopt_iterations']} "
                      f"iterations, Ipopt {st['ipopt_time_s']} s of {st['start_time_s']} s; "
                      "rounds " + ", ".join(f"{r['placement'] or r['round']}: "
                                            f"{r['iterations']} it {r['time_s']} s"
                                            + (f" ({r['variant_constraints']} variant pairs)"
                                               if r["variant_constraints"] else "")
                                            for r in st["rounds"]))
        return 0
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
